"""The W3C SPARQL 1.0 and 1.1 query-evaluation tests (tests/w3c, W3C licence in tests/w3c/LICENSE),
run over HTTP against a live `urdfkb serve` (waitress on 127.0.0.1, see w3c_harness.py)."""

import pytest

from tests import w3c_harness
from tests.kb_fixtures import fake_runner, running
from urdfkb.kb_server.serve import make_server

pytestmark = pytest.mark.w3c
TOKEN = "w3c"
# Tests that fail here, each with its reason. Every one of them fails the same way when this harness
# runs against `oxigraph serve` 0.5.13 (`python tests/w3c_harness.py http://HOST/query http://HOST/update`):
# 467 of 518 pass on both, and no test passes there and fails here.
LEXICAL = ("Oxigraph keeps numbers, booleans and dates in canonical form, so expected lexical forms "
           "such as \"01\", \"1.0\" or \"3.0E4\" come back canonical (equal by value)")
REDUCED = "REDUCED may drop any number of duplicates; this harness compares exact multisets"
ENGINE = "Oxigraph 0.5.13 answers differently (the same answer `oxigraph serve` gives)"
EXCEPTIONS = {
    "data-r2/distinct/manifest#distinct-1": ENGINE,
    "data-r2/distinct/manifest#distinct-9": ENGINE,
    "data-r2/distinct/manifest#no-distinct-1": LEXICAL,
    "data-r2/distinct/manifest#no-distinct-9": LEXICAL,
    "data-r2/expr-builtin/manifest#case-insensitive-booleans": ENGINE,
    "data-r2/expr-builtin/manifest#dawg-str-1": ENGINE,
    "data-r2/expr-builtin/manifest#dawg-str-2": ENGINE,
    "data-r2/expr-builtin/manifest#sameTerm-eq": ENGINE,
    "data-r2/expr-builtin/manifest#sameTerm-not-eq": ENGINE,
    "data-r2/expr-builtin/manifest#sameTerm-simple": ENGINE,
    "data-r2/expr-equals/manifest#eq-graph-1": ENGINE,
    "data-r2/expr-equals/manifest#eq-graph-2": ENGINE,
    "data-r2/graph/manifest#graph-optional": ENGINE,
    "data-r2/graph/manifest#graph-variable-scope": ENGINE,
    "data-r2/open-world/manifest#date-2": ENGINE,
    "data-r2/open-world/manifest#date-3": ENGINE,
    "data-r2/open-world/manifest#open-eq-01": ENGINE,
    "data-r2/open-world/manifest#open-eq-03": LEXICAL,
    "data-r2/open-world/manifest#open-eq-04": LEXICAL,
    "data-r2/reduced/manifest#reduced-1": REDUCED,
    "data-r2/reduced/manifest#reduced-2": REDUCED,
    "data-sparql11/aggregates/manifest#agg-avg-02": LEXICAL,
    "data-sparql11/aggregates/manifest#agg-empty-group-count-graph": ENGINE,
    "data-sparql11/aggregates/manifest#agg-err-02": LEXICAL,
    "data-sparql11/aggregates/manifest#agg-groupconcat-04": ENGINE,
    "data-sparql11/aggregates/manifest#agg-groupconcat-06": ENGINE,
    "data-sparql11/aggregates/manifest#agg-max-01": LEXICAL,
    "data-sparql11/aggregates/manifest#agg-max-02": LEXICAL,
    "data-sparql11/aggregates/manifest#agg-max-distinct": LEXICAL,
    "data-sparql11/aggregates/manifest#agg-min-01": LEXICAL,
    "data-sparql11/aggregates/manifest#agg-min-02": LEXICAL,
    "data-sparql11/aggregates/manifest#agg-min-distinct": LEXICAL,
    "data-sparql11/aggregates/manifest#agg-sum-02": LEXICAL,
    "data-sparql11/bindings/manifest#graph": ENGINE,
    "data-sparql11/cast/manifest#cast-bool": ENGINE,
    "data-sparql11/cast/manifest#cast-decimal": ENGINE,
    "data-sparql11/cast/manifest#cast-double": ENGINE,
    "data-sparql11/cast/manifest#cast-float": ENGINE,
    "data-sparql11/cast/manifest#cast-int": ENGINE,
    "data-sparql11/cast/manifest#cast-string": ENGINE,
    "data-sparql11/csv-tsv-res/manifest#csv03": ENGINE,
    "data-sparql11/csv-tsv-res/manifest#tsv03": ENGINE,
    "data-sparql11/functions/manifest#bnode01": ENGINE,
    "data-sparql11/functions/manifest#coalesce01": LEXICAL,
    "data-sparql11/functions/manifest#plus-1-corrected": LEXICAL,
    "data-sparql11/functions/manifest#plus-2-corrected": LEXICAL,
    "data-sparql11/negation/manifest#graph-minus": ENGINE,
    "data-sparql11/property-path/manifest#zero_or_more_set_end": ENGINE,
    "data-sparql11/property-path/manifest#zero_or_more_set_start": ENGINE,
    "data-sparql11/property-path/manifest#zero_or_one_set_end": ENGINE,
    "data-sparql11/property-path/manifest#zero_or_one_set_start": ENGINE,
}


@pytest.fixture(scope="module")
def endpoint(tmp_path_factory):
    server, store, jobs = make_server(tmp_path_factory.mktemp("w3c") / "kb.sqlite3", port=0, token=TOKEN,
                                      runner=fake_runner(), threads=4)
    with running(server):
        yield w3c_harness.Endpoint(f"http://127.0.0.1:{server.effective_port}/sparql", token=TOKEN)
    jobs.shutdown()
    store.close()


@pytest.mark.parametrize("case", w3c_harness.cases(), ids=str)
def test_w3c_query_evaluation(endpoint, case):
    if case.id in EXCEPTIONS:
        pytest.xfail(EXCEPTIONS[case.id])
    assert w3c_harness.run(case, endpoint) is None
