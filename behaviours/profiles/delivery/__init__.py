"""RelayBot, the delivery robot (seed relaybot-delivery-design.md): its foundations.

Orders and QR verification (``qr_payload``, ``orders``), the box and LEDs (``box``), the seed's
state table (``states``) and config (``config``). The mission's tasks need the navigation glue
and are not here yet, so the profile is not registered (see docs/delivery.md).
"""
