"""The simulator's side of mapping: recorded runs written as CARMEN logs."""
