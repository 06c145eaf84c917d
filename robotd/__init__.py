"""robotd: an asyncio robot runtime for the Raspberry Pi."""

__version__ = "0.1.0"
