"""Deploying a run with docker compose: the compose file of a scenario."""
