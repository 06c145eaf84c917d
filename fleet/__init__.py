"""The laundry fleet server (seed 000, server side): HTTP API, request lifecycle, database."""
