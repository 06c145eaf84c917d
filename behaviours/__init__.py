"""The robot framework (machine, tables, context, profiles, services); capabilities below."""
