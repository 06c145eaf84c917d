"""The control socket: JSON-RPC 2.0, one JSON object per line, over a Unix stream socket."""

from robotd.control.rpc import RpcError
from robotd.control.server import Client, ControlServer

__all__ = ["Client", "ControlServer", "RpcError"]
