"""Settings shared by every test folder (``hypothesis_profile``)."""

import hypothesis_profile  # noqa: F401
