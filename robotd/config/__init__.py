"""Configuration: the schema of every section, the TOML loader, and live settings."""

from robotd.config.errors import ConfigError, ConfigProblem
from robotd.config.loader import load_config, load_config_text
from robotd.config.settings import Settings

__all__ = ["ConfigError", "ConfigProblem", "Settings", "load_config", "load_config_text"]
