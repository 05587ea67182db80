"""Defaults of the server's resource limits (`urdfkb serve` options), in one place; README, Security."""

MAX_RESULT_ROWS = 100_000  # rows (or triples) of one query answer: --max-result-rows
MAX_RESULT_BYTES = 32 * 1024 * 1024  # bytes of one serialised query answer: --max-result-bytes
MAX_CONNECTIONS = 1_000  # open client connections; more wait in the listen backlog: --max-connections
CHANNEL_TIMEOUT = 30  # seconds a connection may stay idle (nothing received or sent): --channel-timeout
