"""Navigation on a known map: maps, localisation, planning and people in the scan."""
