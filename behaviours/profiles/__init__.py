"""One package per robot profile (square, laundry, ...): its states, services and config."""
