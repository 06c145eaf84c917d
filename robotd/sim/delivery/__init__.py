"""The simulator's parts for the delivery robot: its success conditions."""
