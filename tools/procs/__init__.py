"""The processes of a run: launching, supervising, forking agents, their CPU."""
