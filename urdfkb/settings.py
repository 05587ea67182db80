"""Every default, in one place: the library's, the `urdfkb` command's, the server's and the client's.

Options override them (README, Security); this module only names the defaults, so that the command
line, the server, the library and the pages cannot drift apart. Where a page or a bundled query needs
one, it is served from here: the review threshold reaches the templates through the app's context and
the `low_confidence` query's default through its `{REVIEW_THRESHOLD}` placeholder (kb_server.queries).
Standard library only: the client imports it.

Not here: the xacro expansion's own caps (pipeline/reading/xacro_worker.py), which run sandboxed where this
package cannot be imported, and the method's parameters (geometry tolerances, prompt sizes), which
live beside the code they tune.
"""

# Input
MAX_BYTES = 10_000_000  # bytes of a URDF or xacro document, and of a request body: --max-bytes (populate), 413
MAX_LINKS = 5_000  # links or joints of one robot (the largest real robots have a few hundred): --max-links
MAX_XML_ELEMENTS = 250_000  # elements of a URDF document (PR2 has 2,564; 50 a link at MAX_LINKS): refused as parsed
MAX_XML_ATTRIBUTES = 250_000  # attributes of a URDF document (PR2 has 2,671; the truth robots at most 35 a link)
MAX_XML_DEPTH = 100  # levels of elements nested in a URDF document (real URDFs nest under 10)
MAX_JSON_DEPTH = 32  # arrays and objects nested in a JSON request body (a correction needs 2): 400
MAX_REVIEWER = 100  # characters of a correction's reviewer name kept
XACRO_TIMEOUT = 10.0  # seconds of wall time one xacro expansion may take (its process group is killed): --xacro-timeout
XACRO_CPU_SECONDS = 10  # seconds of CPU time the xacro process may use (rlimit)
XACRO_MEMORY = 1 << 30  # bytes of address space of the xacro process (rlimit)

# SPARQL
QUERY_TIMEOUT = 10.0  # seconds a query or update may run (a worker past it is killed): 503
QUERY_WORKERS = 3  # worker processes answering SPARQL, each with a replica of the index
QUERY_MEMORY = 1024 * 2**20  # bytes of address space one query worker may use (a query needing more: 503): --query-memory
MAX_QUERY_NESTING = 256  # nested (), {} and []: far beyond any real query, far below the parser's stack: 400
MAX_RESULT_ROWS = 100_000  # rows (or triples) of one query answer: --max-result-rows
MAX_RESULT_BYTES = 32 * 1024 * 1024  # bytes of one serialised query answer: --max-result-bytes
RESULT_CACHE = 64 * 2**20  # bytes of query answers kept until the next write (0: none): --result-cache

# HTTP
HOST = "127.0.0.1"  # the address `urdfkb serve` binds: --host
PORT = 8000  # its port: --port
THREADS = 16  # waitress threads answering requests
MAX_HEADER = 32_768  # bytes of a request's headers: 431
MAX_DISCARD = 256 * 2**20  # bytes of a refused (413) body read and dropped so the client reads the 413 (64 MiB: 0.1-0.5 s)
MAX_CONNECTIONS = 1_000  # open client connections; more wait in the listen backlog: --max-connections
CHANNEL_TIMEOUT = 30  # seconds a connection may stay idle (nothing received or sent): --channel-timeout
HEADER_TIMEOUT = 10.0  # seconds from a request's first byte to the end of its headers: --header-timeout
BODY_TIMEOUT = 60.0  # seconds from the end of a request's headers to the end of its body (10 MB: 170 kB/s): --body-timeout
REMOTE_TIMEOUT = 30.0  # seconds one request to the --remote-store endpoint may take
MAX_ERROR = 4_096  # characters of an error kept with a job or written to the log; the rest is cut, its length said

# Populate jobs (kb_server.jobs)
JOB_THREADS = 2  # threads running jobs (their pipelines share one model thread)
MAX_QUEUED_JOBS = 8  # jobs waiting for a thread; one more: 429
QUEUE_RETRY_AFTER = 30  # seconds the 429 of a full queue asks the client to wait (Retry-After)
KEEP_JOBS = 100  # finished jobs remembered (GET /jobs/<id>), the newest
KEEP_JOB_SECONDS = 3600.0  # seconds a finished job is remembered
JOB_WAIT = 30.0  # seconds GET /jobs/<id>?wait=1 waits at most (also its default)
WAIT_RETRY_AFTER = 1  # seconds the 429 of too many waiting clients asks them to wait (Retry-After)

# The model (pipeline.abstraction.oracle, pipeline.llm)
VOTES = 5  # samples per question with --vote sample: --votes
MAX_VOTES = 100  # the most --votes may ask for
TEMPERATURE = 0.7  # of those samples
RETRIES = 2  # times a sampled answer outside the options is asked again before it counts as an abstention
LLM_TIMEOUT = 60  # seconds one request to an OpenAI-compatible server (--llm-url) may take
MAX_LLM_REPLY = 10_000_000  # bytes of its answer (a chat completion of a few short answers is a few kilobytes)
PREFIX_CACHE_BYTES = 512 << 20  # the prompt-state cache's size bound (the sixteen truth robots leave 27 states,
# 150 MB; Qwen2.5-1.5B: 28 KB a token)

# Questions in words (kb_server.ask)
ASK_THRESHOLD = 0.3  # probability the chosen query's options must hold together; less is a refusal
MAX_QUESTION = 500  # characters of a question: 400

# Review
REVIEW_THRESHOLD = 0.5  # confidence below which a component or sub-component is shown for review

# The client (urdfkb.client)
CLIENT_TIMEOUT = 10.0  # seconds the client waits for the server's answer
ASK_TIMEOUT = 60.0  # seconds it waits for the answer to a question in words (the first reads the robot's menu)


def job_waiters(threads: int) -> int:
    """Clients that may wait on a job at once: a quarter of the server threads (at least one), so waits
    never hold every thread."""
    return max(1, threads // 4)
