"""The seed's algorithms, one module each; every function runs inside a caller's transaction."""
