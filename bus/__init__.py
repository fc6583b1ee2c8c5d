"""The wire contract shared by agents, the world and the tools."""
