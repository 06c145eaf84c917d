"""The HTTP API: routers, request/response bodies, error answers."""
