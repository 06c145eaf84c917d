"""The site console (issue 29): staff and customer pages served by the fleet server."""
