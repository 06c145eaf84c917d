"""Alembic migrations of the fleet database (shipped as package data, run at start)."""
