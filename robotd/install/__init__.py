"""Installing robotd on a robot: accounts, versioned virtual environments, config, udev, units.

``scripts/install-robot`` runs ``python3 -m robotd.install`` from a checkout with the system's
Python (this package uses the standard library only: it runs before any virtual environment
exists); ``robotd update`` (robotd/update.py) installs later versions beside the current one.
"""
