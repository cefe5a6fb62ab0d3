"""Shared fixtures: the real services (redis-server, Celery workers) live in service_fixtures."""

pytest_plugins = ["service_fixtures"]
