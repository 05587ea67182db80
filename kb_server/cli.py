"""The `urdfkb` command: a thin layer over the pipeline and the knowledge-base server."""
from __future__ import annotations

import argparse
import contextlib
import json
import os
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING, Sequence

from urdfkb import __version__, local_name
from urdfkb.pipeline.errors import UrdfkbError
from urdfkb.pipeline.knowledge.formats import BY_NAME, RESULTS_BY_NAME
from urdfkb.settings import (BODY_TIMEOUT, CHANNEL_TIMEOUT, HEADER_TIMEOUT, HOST, MAX_BYTES, MAX_CONNECTIONS, MAX_LINKS,
                             MAX_RESULT_BYTES, MAX_RESULT_ROWS, PORT, QUERY_MEMORY, RESULT_CACHE, TEMPERATURE, VOTES,
                             XACRO_TIMEOUT)

if TYPE_CHECKING:
    from tqdm import tqdm

DEFAULT_TRUTH = Path("..") / "shared" / "eval" / "truth"
FOLDS = Path(__file__).resolve().parents[1] / "benchmarks" / "folds.yaml"  # in a checkout only


class StageBars:
    """One tqdm bar per stage round on stderr; silent when quiet."""

    def __init__(self, quiet: bool):
        self.quiet = quiet
        self.bar: tqdm | None = None

    def __call__(self, stage: str, done: int, total: int) -> None:
        if self.quiet:
            return
        from tqdm import tqdm
        if self.bar is None or done == 0 or self.bar.desc != stage:
            self.close()
            self.bar = tqdm(total=total, desc=stage, unit="q", leave=True, file=sys.stderr)
        self.bar.update(done - self.bar.n)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def _add_model_options(p: argparse.ArgumentParser) -> None:
    from urdfkb.pipeline.abstraction.oracle import MODES
    g = p.add_argument_group("model")
    g.add_argument("--model", metavar="GGUF", help="a GGUF model file (default: Qwen2.5-Coder-1.5B-Instruct, fetched once)")
    g.add_argument("--llm-url", metavar="URL", help="an OpenAI-compatible server (llama.cpp server, vLLM, Ollama /v1) instead of the embedded model")
    g.add_argument("--llm-model", metavar="NAME", help="the model name to request from --llm-url")
    g.add_argument("--vote", choices=MODES, help="exact: whole-answer probabilities in one pass (default with an embedded model); "
                                                 f"sample: K samples at temperature {TEMPERATURE:g}")
    g.add_argument("--votes", type=int, default=VOTES, metavar="K", help=f"samples per question with --vote sample (default {VOTES})")
    g.add_argument("--no-cache", action="store_true", help="ignore and do not write the result cache")


def _add_xacro_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("xacro")
    g.add_argument("--xacro-arg", metavar="NAME:=VALUE", action="append", default=[], help="a xacro:arg value (repeatable)")
    _add_package_path(g, "where $(find NAME) and package://NAME/ point (repeatable); includes may read only these folders and the file's own")


def _add_package_path(group, help: str) -> None:
    """--package-path NAME=DIR (repeatable): the ROS package folders xacro includes may read, as `help` says for the command."""
    group.add_argument("--package-path", metavar="NAME=DIR", action="append", default=[], help=help)


def _settings(args: argparse.Namespace, structure_only: bool = False):
    from urdfkb.pipeline.runner import Settings
    settings = Settings(structure_only=structure_only, model=args.model, llm_url=args.llm_url,
                        llm_model=args.llm_model, vote=args.vote, votes=args.votes, use_cache=not args.no_cache)
    try:
        settings.check()
    except ValueError as exc:
        raise UrdfkbError(str(exc)) from None
    return settings


def _limits(args: argparse.Namespace) -> dict:
    """The input limits given on the command line: size, count, xacro time (the library's defaults where not given)."""
    return {k: v for k in ("max_bytes", "max_links", "xacro_timeout") if (v := getattr(args, k, None)) is not None}


def _abstract(urdf: str, name: str | None, settings, quiet: bool, trace, timings, limits: dict,
              xacro_args: Sequence[str] = (), package_paths: Sequence[str] = ()):
    """Ingest (expanding xacro) and abstract one robot; returns (tree, robot name, abstraction, seconds)."""
    from urdfkb.pipeline.runner import run
    from urdfkb.pipeline.reading.xacro_input import load_description, parse_args, parse_package_paths
    with timings.stage("ingest"):
        tree = load_description(urdf, args=parse_args(xacro_args), packages=parse_package_paths(package_paths), **limits)
    bars = StageBars(quiet)
    started = time.monotonic()
    try:
        abstraction = run(tree, settings, progress=bars, trace=trace, timings=timings)
    finally:
        bars.close()
    return tree, name or tree.robot_name, abstraction, time.monotonic() - started


def _robot_ontology(tree, name: str, abstraction):
    from urdfkb.pipeline.knowledge import rdf
    from urdfkb.pipeline.knowledge.population import build_robot
    return build_robot(rdf.new_world(), tree, name, abstraction)


def cmd_populate(args: argparse.Namespace) -> int:
    from urdfkb.pipeline.knowledge.export import export_graph, robot_graph
    from urdfkb.pipeline.knowledge.shacl import validate
    from urdfkb.pipeline.timings import Timings
    settings = _settings(args, args.structure_only)
    started = time.perf_counter()
    with open(args.trace, "w") if args.trace else contextlib.nullcontext() as trace:
        timings = Timings(trace)
        if args.startup_seconds:
            timings.record({"stage": "startup", "seconds": round(args.startup_seconds, 4)})
        tree, name, abstraction, seconds = _abstract(args.urdf, args.name, settings, args.quiet, trace, timings,
                                                     _limits(args), args.xacro_arg, args.package_path)
        with timings.stage("population"):
            onto = _robot_ontology(tree, name, abstraction)
            graph = robot_graph(onto)
        with timings.stage("SHACL"):
            conforms, report = validate(graph)
        if not conforms:
            raise UrdfkbError(f"the populated robot breaks the SHACL shapes; nothing written:\n{report}")
        out = args.output or f"{Path(Path(args.urdf).name.removesuffix('.xacro')).stem}.{BY_NAME[args.format].extension}"
        with timings.stage("export"):
            export_graph(graph, out, args.format)
        timings.record({"stage": "total", "seconds": round(args.startup_seconds + time.perf_counter() - started, 4)})
    what = "structure only" if settings.structure_only else f"{len(abstraction.components)} components"
    print(f"{name}: {len(tree.links)} links, {len(tree.edges)} joints, {what} in {seconds:.1f} s -> {Path(out).resolve()}")
    for c in abstraction.components:
        print(f"  {c.kind:12} {c.cls:20} on {c.root:30} {c.confidence:.2f}  {', '.join(c.links)}")
    for h in abstraction.held:
        print(f"  held back for review, not written: {h.cls} {h.name} on {', '.join(h.links)}\n    "
              + "\n    ".join(h.violations))
    if args.timings:
        print(timings.table())
    return 0


def cmd_validate(args: argparse.Namespace) -> int:
    import rdflib
    from urdfkb.pipeline.knowledge.shacl import validate
    try:
        graph = rdflib.Graph().parse(args.file)
    except Exception as exc:  # rdflib raises many parser-specific types
        raise UrdfkbError(f"cannot read {args.file} as RDF: {exc}") from None
    conforms, report = validate(graph)
    print(report if not conforms else f"{args.file}: conforms to the urdfkb shapes")
    return 0 if conforms else 1


def cmd_eval(args: argparse.Namespace) -> int:
    from urdfkb.pipeline.scoring import evaluation, evaluation_report, truth
    from urdfkb.pipeline.scoring.truth_run import run_truth_robot
    truth_dir = Path(args.truth_dir)
    files = sorted(truth_dir.glob("*.yaml"))
    folds = truth.load_folds(args.folds) if args.folds else {}
    if args.fold:
        if unknown_folds := set(args.fold) - set(folds):
            raise UrdfkbError(f"no fold {', '.join(sorted(unknown_folds))} in {args.folds} (folds: {', '.join(folds)})")
        args.robot += [r for f in args.fold for r in folds[f]]
    if args.robot:
        unknown = set(args.robot) - {f.stem for f in files}
        if unknown:
            raise UrdfkbError(f"no truth file for {', '.join(sorted(unknown))} in {truth_dir}")
        files = [f for f in files if f.stem in args.robot]
    if not files:
        raise UrdfkbError(f"no truth files (*.yaml) in {truth_dir}")
    if args.traces:
        Path(args.traces).mkdir(parents=True, exist_ok=True)
    settings = _settings(args)
    per_robot: dict[str, dict] = {}
    extra: dict[str, dict[str, object]] = {
        k: {} for k in ("model", "vote", "llm calls", "tokens", "declared", "seconds")}
    for path in files:
        robot = path.stem
        print(f"== {robot}", file=sys.stderr)
        bars = StageBars(args.quiet)
        trace_path = Path(args.traces) / f"{robot}.jsonl" if args.traces else None
        try:
            with open(trace_path, "w") if trace_path else contextlib.nullcontext() as trace:
                result = run_truth_robot(path, settings, progress=bars, trace=trace)
        except UrdfkbError as exc:
            print(f"{robot}: run failed: {exc}", file=sys.stderr)
            per_robot[robot] = evaluation.failed_scores()
            continue
        finally:
            bars.close()
        per_robot[robot] = result.scores
        if args.explain:
            for line in result.scores["differences"]:
                print(f"  {robot}: {line}", file=sys.stderr)
        prov = result.abstraction.provenance
        extra["model"][robot] = prov.get("model", "?").removeprefix("llama.cpp:")
        extra["vote"][robot] = prov.get("vote", "?") + (f" x{prov.get('votes')}" if prov.get("vote") == "sample" else "")
        extra["llm calls"][robot] = prov.get("llm_calls", "?")
        extra["tokens"][robot] = prov.get("prompt_tokens", "?")
        extra["declared"][robot] = prov.get("declared_constraints", "?")
        extra["seconds"][robot] = f"{result.seconds:.1f}"
    print(evaluation_report.format_table(per_robot, extra, folds))
    if per_robot:
        print(evaluation_report.review_queue(evaluation.mean_scores(per_robot)))
    if args.json:
        Path(args.json).write_text(json.dumps({"robots": per_robot, "mean": evaluation.mean_scores(per_robot),
                                               "folds": evaluation.fold_means(per_robot, folds), "run": extra}, indent=2))
    return 0


def cmd_model(args: argparse.Namespace) -> int:
    from urdfkb.pipeline.llm.fetch import DEFAULT_MODEL, TEST_MODEL, ensure_model
    print(ensure_model(TEST_MODEL if args.test else DEFAULT_MODEL, progress=not args.quiet))
    return 0


def cmd_serve(args: argparse.Namespace) -> int:
    from urdfkb.kb_server.serve import serve
    serve(store_path=args.store, host=args.host, port=args.port, token=args.token or os.environ.get("URDFKB_TOKEN"),
          remote_store=args.remote_store, populate=args.populate, allowed_hosts=args.allowed_host,
          model_dir=args.model_dir, llm_urls=args.allow_llm_url, insecure_no_token=args.insecure_no_token,
          package_paths=args.package_path, trust_xacro=args.trust_xacro, max_result_rows=args.max_result_rows,
          max_result_bytes=args.max_result_bytes, max_connections=args.max_connections,
          channel_timeout=args.channel_timeout, header_timeout=args.header_timeout, body_timeout=args.body_timeout,
          query_memory=args.query_memory * 2**20, result_cache=args.result_cache * 2**20, **_limits(args))
    return 0


def cmd_query(args: argparse.Namespace) -> int:
    from urdfkb.kb_server.queries import run_named_query
    params = dict(p.split("=", 1) for p in args.param)
    print(run_named_query(args.name, robot=args.robot, params=params, store_path=args.store, fmt=args.format))
    return 0


def cmd_mcp(args: argparse.Namespace) -> int:
    from urdfkb.kb_server.mcp_tools import serve_stdio
    from urdfkb.kb_server.store import Store
    store = Store(args.store, workers=1)  # as `urdfkb query`: one worker process, so the query timeout is enforced
    try:
        serve_stdio(store)
    finally:
        store.close()
    return 0


def cmd_ask(args: argparse.Namespace) -> int:
    from urdfkb.kb_server.ask import Asker, direct
    from urdfkb.kb_server.store import Store
    from urdfkb.pipeline.runner import Settings, make_backend
    store = Store(args.store, workers=1)
    try:
        store.require(args.robot)  # before the model loads
        backend = make_backend(Settings(model=args.model))
        try:
            reply = Asker(direct(backend)).ask(store, args.robot, args.question)
        finally:
            backend.close()
    finally:
        store.close()
    if args.json:
        print(json.dumps(reply, indent=2))
        return 0
    columns = list(dict.fromkeys(k for row in reply["rows"] for k in row))
    cells = [[local_name(str(row.get(c, ""))) for c in columns] for row in reply["rows"]]
    widths = [max([len(c)] + [len(r[i]) for r in cells]) for i, c in enumerate(columns)]
    for line in ([columns] if cells else []) + cells:
        print("  ".join(v.ljust(w) for v, w in zip(line, widths)).rstrip())
    print(("\n" if cells else "") + reply["answer"])
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="urdfkb", description="Turn a robot's URDF into a populated, queryable OWL ontology of its sensors and end-effectors.")
    parser.add_argument("--version", action="version", version=f"urdfkb {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("populate", help="abstract a URDF and write the populated ontology to a file",
                       description="Ingest a URDF, run the LLM-guided abstraction (sensors, then end-effectors), check the result against the SHACL shapes and write a self-contained ontology file that opens in Protégé offline.")
    p.add_argument("urdf", help="the robot's URDF or xacro file (.xacro, or a document using xacro elements or ${...} substitutions)")
    p.add_argument("-o", "--output", help="output file (default: <urdf stem>.owl/.ttl/.nt in the current directory)")
    p.add_argument("--format", choices=tuple(BY_NAME), default="rdfxml", help="output syntax (default rdfxml)")
    p.add_argument("--name", help="robot name in the ontology (default: the URDF's robot name)")
    p.add_argument("--structure-only", action="store_true", help="skip the model: links and joints only")
    p.add_argument("--trace", metavar="FILE", help="write a JSON-lines audit of every question: candidates, distribution, answer")
    p.add_argument("--timings", action="store_true", help="print where the time went: start-up, model load, each pass's steps "
                   "(seconds, model seconds, tokens, decodes, reasoner), population, SHACL, export (also in --trace)")
    p.add_argument("--max-bytes", type=int, help=f"refuse URDFs larger than this (default {MAX_BYTES / 1e6:g} MB)")
    p.add_argument("--max-links", type=int, metavar="N", help=f"refuse URDFs with more links or joints than this (default {MAX_LINKS:,})")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    _add_xacro_options(p)
    _add_model_options(p)
    p.set_defaults(func=cmd_populate)

    p = sub.add_parser("validate", help="check a populated ontology file against the urdfkb SHACL shapes")
    p.add_argument("file", help="an RDF file written by `urdfkb populate` (any RDF syntax)")
    p.set_defaults(func=cmd_validate)

    p = sub.add_parser("eval", help="score the pipeline against ground-truth robots",
                       description="Run the pipeline on each truth robot and print the metrics of ../shared/spec/evaluation.md per robot and their mean, with model, voting, LLM calls, tokens and wall time.")
    p.add_argument("truth_dir", nargs="?", default=str(DEFAULT_TRUTH), help=f"folder of truth *.yaml files (default {DEFAULT_TRUTH}); URDF paths in them are relative to its grandparent")
    p.add_argument("--json", metavar="FILE", help="also write the scores as JSON")
    p.add_argument("--traces", metavar="DIR", help="write each robot's question trace to DIR/<robot>.jsonl")
    p.add_argument("--explain", action="store_true",
                   help="after each robot, print what it got wrong (missed, extra, mistyped, misrooted components and sub-parts)")
    p.add_argument("--robot", action="append", default=[], metavar="NAME",
                   help="only this truth robot (a file stem; repeatable)")
    p.add_argument("--folds", metavar="FILE", default=str(FOLDS) if FOLDS.exists() else None,
                   help="a folds file (robots by family); each fold's mean is printed under the robots "
                        "(default: benchmarks/folds.yaml of this checkout)")
    p.add_argument("--fold", action="append", default=[], metavar="NAME",
                   help="only the robots of this fold of --folds (repeatable)")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bars")
    _add_model_options(p)
    p.set_defaults(func=cmd_eval)

    p = sub.add_parser("model", help="fetch, assemble and verify the default model (cached; instant once done)")
    p.add_argument("--test", action="store_true", help="the small SmolLM2-135M test model instead")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_model)

    p = sub.add_parser("serve", help="serve the knowledge base: SPARQL endpoint, POST /populate, robots, HRI queries")
    p.add_argument("--store", help="the quadstore file (default: a kb.sqlite3 in the user data directory)")
    p.add_argument("--host", default=HOST, help=f"address to bind (default {HOST})")
    p.add_argument("--port", type=int, default=PORT, help=f"port, 1-65535 (default {PORT}; 0: any free port)")
    p.add_argument("--token", help="bearer token allowing SPARQL updates and deletions (or env URDFKB_TOKEN)")
    p.add_argument("--remote-store", metavar="URL", help="mirror every robot as a named graph into this SPARQL 1.1 Graph Store endpoint")
    p.add_argument("--populate", metavar="URDF", action="append", default=[], help="populate this URDF into the store before serving (repeatable)")
    g = p.add_argument_group("security (what strangers may make the server do; see README, Security)")
    g.add_argument("--allowed-host", metavar="NAME", action="append", default=[], help="also answer to this Host name, or NAME:PORT (repeatable; default: only the bind address, or the loopback names on a loopback bind)")
    g.add_argument("--model-dir", metavar="DIR", help="let POST /populate choose model=FILE.gguf among the GGUF files of this directory (default: model= refused)")
    g.add_argument("--allow-llm-url", metavar="URL", action="append", default=[], help="let POST /populate use this OpenAI-compatible http(s) server as llm_url (repeatable; default: llm_url= refused)")
    g.add_argument("--insecure-no-token", action="store_true", help="serve on a non-loopback --host without --token: anyone who can reach the port can populate robots")
    g.add_argument("--max-links", type=int, metavar="N", help=f"refuse URDFs with more links or joints than this (default {MAX_LINKS:,})")
    _add_package_path(g, "let uploaded xacro files include from this ROS package folder via $(find NAME) or package://NAME/ "
                         "(repeatable; without it, uploads read no server file)")
    g.add_argument("--xacro-timeout", type=float, metavar="S", help="stop an uploaded xacro's expansion (its job fails) "
                   f"after this many seconds of wall time (default {XACRO_TIMEOUT:g})")
    g.add_argument("--trust-xacro", action="store_true", help="expand uploaded xacro files without the operating-system "
                   "sandbox (bubblewrap + seccomp): only where every client may run code as the server's user")
    g.add_argument("--max-result-rows", type=int, default=MAX_RESULT_ROWS, metavar="N",
                   help=f"refuse (413) query answers with more rows or triples (default {MAX_RESULT_ROWS:,})")
    g.add_argument("--max-result-bytes", type=int, default=MAX_RESULT_BYTES, metavar="N",
                   help=f"refuse (413) query answers longer than this serialised (default {MAX_RESULT_BYTES:,})")
    g.add_argument("--query-memory", type=int, default=QUERY_MEMORY // 2**20, metavar="MIB",
                   help="address space one SPARQL worker may use; a query needing more is stopped with 503 "
                        f"(default {QUERY_MEMORY // 2**20:,} MiB)")
    g.add_argument("--result-cache", type=int, default=RESULT_CACHE // 2**20, metavar="MIB",
                   help="keep query answers in memory until the next write, at most this much, and answer the same "
                        f"query again from there (default {RESULT_CACHE // 2**20} MiB; 0: keep none)")
    g.add_argument("--max-connections", type=int, default=MAX_CONNECTIONS, metavar="N",
                   help=f"open client connections at most; a new one then closes the connection waiting longest "
                        f"for its request (default {MAX_CONNECTIONS:,})")
    g.add_argument("--channel-timeout", type=int, default=CHANNEL_TIMEOUT, metavar="S",
                   help=f"close a connection idle this many seconds (default {CHANNEL_TIMEOUT})")
    g.add_argument("--header-timeout", type=float, default=HEADER_TIMEOUT, metavar="S",
                   help=f"close a connection whose request headers are not all in S seconds after its first byte "
                        f"(default {HEADER_TIMEOUT:g})")
    g.add_argument("--body-timeout", type=float, default=BODY_TIMEOUT, metavar="S",
                   help=f"close a connection whose request body is not all in S seconds after its headers "
                        f"(default {BODY_TIMEOUT:g})")
    p.set_defaults(func=cmd_serve)

    p = sub.add_parser("query", help="run one of the bundled HRI queries against the store")
    p.add_argument("name", help="query name (a file in queries/, without .rq)")
    p.add_argument("--robot", required=True, help="robot name")
    p.add_argument("--param", action="append", default=[], metavar="KEY=VALUE", help="query parameter (repeatable)")
    p.add_argument("--store", help="the quadstore file (default: the server's default store)")
    p.add_argument("--format", choices=("table", *RESULTS_BY_NAME), default="table",
                   help="output format: an aligned table (the default) or SPARQL results as JSON, XML, CSV or TSV")
    p.set_defaults(func=cmd_query)

    p = sub.add_parser("mcp", help="serve the bundled queries as MCP tools over stdio (for an LLM agent's host)",
                       description="A Model Context Protocol server on stdin/stdout: one tool per bundled query, "
                                   "plus robots and a read-only sparql, and each robot's export as a resource.")
    p.add_argument("--store", help="the quadstore file (default: the server's default store)")
    p.set_defaults(func=cmd_mcp)

    p = sub.add_parser("ask", help="ask a stored robot a question in words; one bundled query answers it, or it is refused",
                       description="The embedded model chooses the bundled query and its values among the options the "
                                   "knowledge base offers for the robot, or none of them; the rows and one sentence "
                                   "composed from them are printed (no generated text).")
    p.add_argument("robot", help="robot name")
    p.add_argument("question", help="the question, in English")
    p.add_argument("--store", help="the quadstore file (default: the server's default store)")
    p.add_argument("--json", action="store_true", help="print the whole reply as JSON (query, params, rows, answer, "
                                                       "confidence, refused)")
    p.add_argument("--model", metavar="GGUF", help="a GGUF model file (default: Qwen2.5-Coder-1.5B-Instruct, fetched once)")
    p.set_defaults(func=cmd_ask)
    return parser


def main(argv: list[str] | None = None) -> int:
    from urdfkb.pipeline.timings import process_age
    startup = process_age() if argv is None else 0.0  # the interpreter's start and imports, run as a program
    args = build_parser().parse_args(argv)
    args.startup_seconds = startup
    try:
        return args.func(args)
    except UrdfkbError as exc:
        print(f"urdfkb: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("urdfkb: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
