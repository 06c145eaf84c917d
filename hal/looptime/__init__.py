"""Loop-time helpers: timer chains, sleeps and deadlines on the event loop's (virtual) clock."""
