"""Deploying a run: docker compose files and the secured mode's certificates."""
