"""What the sender hears about the frame in flight, and which of it tells most.

Replies (``Ack``, ``Hello``, ``Nak``) come from the line; ``Evidence`` says a frame may be
lost (a garbled line, ``NAK:CRC`` without a readable SEQ, a reboot, telemetry after the reply
was due); ``Preempted`` says STOP wants the line. Several may arrive before the sender looks:
it acts on the most telling one (``rank``: ACK beats NAK beats the rest), and resends before
the timeout only on what ``worth_fast_resend`` accepts.
"""

from __future__ import annotations

from typing import NamedTuple

from drivers.arduino.framing import Ack, Hello, Nak

# Fast resends per command are also bounded by count, so a line that garbles everything
# cannot make the sender spin when the wire takes no time (the in-memory pipe).
MAX_FAST_RESENDS = 32
# Slack for USB serial adapters that hold bytes back before passing them on (FTDI: 16 ms).
USB_LATENCY_S = 0.02
# Bytes of the longest reply (``#255 NAK:PARSE*CC\n``), to know when a reply is due.
REPLY_BYTES = 18


class Preempted:
    """Mailbox marker: STOP wants the line now."""


class Evidence(NamedTuple):
    """Mailbox marker: our frame may be lost (garbled line, NAK:CRC, reboot, later telemetry).

    ``definite``: resend at once. ``intact``: an intact telemetry line, which tells only once
    the reply is overdue, since the MCU answers a frame before it sends further telemetry.
    """

    definite: bool = False
    intact: bool = False


Event = Ack | Hello | Nak | Preempted | Evidence


def rank(event: Event) -> int:
    if isinstance(event, Ack | Hello):
        return 0
    if isinstance(event, Nak) and event.reason != "CRC":
        return 1
    if isinstance(event, Preempted):
        return 2
    return 3


def worth_fast_resend(event: Event, *, fast: int, since_last_s: float, since_first_s: float,
                      give_up_s: float, reply_due_s: float, recent_rtt_s: float) -> bool:
    """Whether ``event`` calls for sending the frame in flight again before its timeout.

    Args:
        fast: resends made so far before a timeout.
        since_last_s, since_first_s: time since the latest and the first transmission.
        give_up_s: no fast resend once this long has passed since the first.
        reply_due_s: how long after a transmission its reply is due on the wire.
        recent_rtt_s: the shortest recent round trip (0 when none yet).
    """
    if fast >= MAX_FAST_RESENDS or since_first_s >= give_up_s:
        return False
    if isinstance(event, Nak) or (isinstance(event, Evidence) and event.definite):
        return True
    # Other lines only tell something once the reply to our frame was due.
    due_s = reply_due_s
    if isinstance(event, Evidence) and event.intact:
        # Lines the MCU sent just before our frame reached it come one round trip later.
        due_s = max(due_s, recent_rtt_s) + USB_LATENCY_S
    return since_last_s >= due_s
