"""Every default size and time limit, in one place: the library's, the `urdfkb` command's and the server's.

Options override them (README, Security); this module only names the defaults, so that the command
line, the server and the library cannot drift apart.
"""

# Input
MAX_BYTES = 10_000_000  # bytes of a URDF or xacro document, and of a request body: --max-bytes (populate), 413
MAX_LINKS = 5_000  # links or joints of one robot (the largest real robots have a few hundred): --max-links
MAX_XML_ELEMENTS = 250_000  # elements of a URDF document (PR2 has 2,564; 50 a link at MAX_LINKS): refused as parsed
MAX_XML_ATTRIBUTES = 250_000  # attributes of a URDF document (PR2 has 2,671; the truth robots at most 35 a link)
MAX_JSON_DEPTH = 32  # arrays and objects nested in a JSON request body (a correction needs 2): 400
XACRO_TIMEOUT = 10.0  # seconds of wall time one xacro expansion may take (its process group is killed): --xacro-timeout

# SPARQL
QUERY_TIMEOUT = 10.0  # seconds a query or update may run (a worker past it is killed): 503
QUERY_WORKERS = 3  # worker processes answering SPARQL, each with a replica of the index
QUERY_MEMORY = 1024 * 2**20  # bytes of address space one query worker may use (a query needing more: 503): --query-memory
MAX_RESULT_ROWS = 100_000  # rows (or triples) of one query answer: --max-result-rows
MAX_RESULT_BYTES = 32 * 1024 * 1024  # bytes of one serialised query answer: --max-result-bytes

# HTTP
THREADS = 16  # waitress threads answering requests
MAX_HEADER = 32_768  # bytes of a request's headers: 431
MAX_CONNECTIONS = 1_000  # open client connections; more wait in the listen backlog: --max-connections
CHANNEL_TIMEOUT = 30  # seconds a connection may stay idle (nothing received or sent): --channel-timeout
HEADER_TIMEOUT = 10.0  # seconds from a request's first byte to the end of its headers: --header-timeout
BODY_TIMEOUT = 60.0  # seconds from the end of a request's headers to the end of its body (10 MB: 170 kB/s): --body-timeout
JOB_WAIT = 30.0  # seconds GET /jobs/<id>?wait=1 waits at most (also its default)
REMOTE_TIMEOUT = 30.0  # seconds one request to the --remote-store endpoint may take
MAX_ERROR = 4_096  # characters of an error kept with a job or written to the log; the rest is cut, its length said


def job_waiters(threads: int) -> int:
    """Clients that may wait on a job at once: a quarter of the server threads (at least one), so waits
    never hold every thread."""
    return max(1, threads // 4)
