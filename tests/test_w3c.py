"""The W3C SPARQL 1.0 and 1.1 query-evaluation tests (tests/w3c, W3C licence in tests/w3c/LICENSE),
run over HTTP against a live `urdfkb serve` (waitress on 127.0.0.1, see w3c_harness.py)."""
import threading

import pytest

import w3c_harness
from kb_fixtures import fake_runner
from kb_server.serve import make_server

TOKEN = "w3c"
# Tests that fail here, each with its reason. Every one of them fails the same way when this harness
# runs against `oxigraph serve` 0.5.13 (`python tests/w3c_harness.py http://HOST/query http://HOST/update`):
# 453 of 518 pass on both, and no test passes there and fails here.
CSV = "the harness cannot read the expected CSV (pyoxigraph refuses to parse lossy CSV results)"
DATASET = "the data files this query names in FROM live in another folder the harness does not load"
SAME = ("answer differs from the expected one identically on `oxigraph serve` 0.5.13: Oxigraph's evaluation "
        "or this harness's strict comparison (lexical forms, ORDER BY ties), not urdfkb's dataset or protocol")
EXCEPTIONS = {
    "data-r2/dataset/manifest#dawg-dataset-01": DATASET,
    "data-r2/dataset/manifest#dawg-dataset-02": DATASET,
    "data-r2/dataset/manifest#dawg-dataset-03": DATASET,
    "data-r2/dataset/manifest#dawg-dataset-04": DATASET,
    "data-r2/dataset/manifest#dawg-dataset-05": DATASET,
    "data-r2/dataset/manifest#dawg-dataset-06": DATASET,
    "data-r2/dataset/manifest#dawg-dataset-07": DATASET,
    "data-r2/dataset/manifest#dawg-dataset-08": DATASET,
    "data-r2/dataset/manifest#dawg-dataset-09b": DATASET,
    "data-r2/dataset/manifest#dawg-dataset-10b": DATASET,
    "data-r2/dataset/manifest#dawg-dataset-11": DATASET,
    "data-r2/dataset/manifest#dawg-dataset-12b": DATASET,
    "data-r2/distinct/manifest#distinct-1": SAME,
    "data-r2/distinct/manifest#distinct-9": SAME,
    "data-r2/distinct/manifest#no-distinct-1": SAME,
    "data-r2/distinct/manifest#no-distinct-9": SAME,
    "data-r2/expr-builtin/manifest#case-insensitive-booleans": SAME,
    "data-r2/expr-builtin/manifest#dawg-str-1": SAME,
    "data-r2/expr-builtin/manifest#dawg-str-2": SAME,
    "data-r2/expr-builtin/manifest#sameTerm-eq": SAME,
    "data-r2/expr-builtin/manifest#sameTerm-not-eq": SAME,
    "data-r2/expr-builtin/manifest#sameTerm-simple": SAME,
    "data-r2/expr-equals/manifest#eq-graph-1": SAME,
    "data-r2/expr-equals/manifest#eq-graph-2": SAME,
    "data-r2/graph/manifest#graph-optional": SAME,
    "data-r2/graph/manifest#graph-variable-scope": SAME,
    "data-r2/open-world/manifest#date-2": SAME,
    "data-r2/open-world/manifest#date-3": SAME,
    "data-r2/open-world/manifest#open-eq-01": SAME,
    "data-r2/open-world/manifest#open-eq-03": SAME,
    "data-r2/open-world/manifest#open-eq-04": SAME,
    "data-r2/reduced/manifest#reduced-1": SAME,
    "data-r2/reduced/manifest#reduced-2": SAME,
    "data-sparql11/aggregates/manifest#agg-avg-02": SAME,
    "data-sparql11/aggregates/manifest#agg-empty-group-count-graph": SAME,
    "data-sparql11/aggregates/manifest#agg-err-02": SAME,
    "data-sparql11/aggregates/manifest#agg-groupconcat-04": SAME,
    "data-sparql11/aggregates/manifest#agg-groupconcat-06": SAME,
    "data-sparql11/aggregates/manifest#agg-max-01": SAME,
    "data-sparql11/aggregates/manifest#agg-max-02": SAME,
    "data-sparql11/aggregates/manifest#agg-max-distinct": SAME,
    "data-sparql11/aggregates/manifest#agg-min-01": SAME,
    "data-sparql11/aggregates/manifest#agg-min-02": SAME,
    "data-sparql11/aggregates/manifest#agg-min-distinct": SAME,
    "data-sparql11/aggregates/manifest#agg-sum-02": SAME,
    "data-sparql11/bindings/manifest#graph": SAME,
    "data-sparql11/cast/manifest#cast-bool": SAME,
    "data-sparql11/cast/manifest#cast-decimal": SAME,
    "data-sparql11/cast/manifest#cast-double": SAME,
    "data-sparql11/cast/manifest#cast-float": SAME,
    "data-sparql11/cast/manifest#cast-int": SAME,
    "data-sparql11/cast/manifest#cast-string": SAME,
    "data-sparql11/csv-tsv-res/manifest#csv01": CSV,
    "data-sparql11/csv-tsv-res/manifest#csv02": CSV,
    "data-sparql11/csv-tsv-res/manifest#csv03": CSV,
    "data-sparql11/csv-tsv-res/manifest#tsv03": SAME,
    "data-sparql11/functions/manifest#bnode01": SAME,
    "data-sparql11/functions/manifest#coalesce01": SAME,
    "data-sparql11/functions/manifest#plus-1-corrected": SAME,
    "data-sparql11/functions/manifest#plus-2-corrected": SAME,
    "data-sparql11/negation/manifest#graph-minus": SAME,
    "data-sparql11/property-path/manifest#zero_or_more_set_end": SAME,
    "data-sparql11/property-path/manifest#zero_or_more_set_start": SAME,
    "data-sparql11/property-path/manifest#zero_or_one_set_end": SAME,
    "data-sparql11/property-path/manifest#zero_or_one_set_start": SAME,
}


@pytest.fixture(scope="module")
def endpoint(tmp_path_factory):
    server, store, jobs = make_server(tmp_path_factory.mktemp("w3c") / "kb.sqlite3", port=0, token=TOKEN,
                                      runner=fake_runner(), threads=4)
    thread = threading.Thread(target=server.run, daemon=True)
    thread.start()
    yield w3c_harness.Endpoint(f"http://127.0.0.1:{server.effective_port}/sparql", token=TOKEN)
    server.close()
    jobs.shutdown()
    store.close()


@pytest.mark.parametrize("case", w3c_harness.cases(), ids=str)
def test_w3c_query_evaluation(endpoint, case):
    if case.id in EXCEPTIONS:
        pytest.xfail(EXCEPTIONS[case.id])
    assert w3c_harness.run(case, endpoint) is None
