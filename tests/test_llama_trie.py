"""The llama.cpp backend's option trie and constrained draws, on token ids alone (no model)."""
import math
import random

import pytest

from urdfkb.pipeline.llm.option_trie import OptionJob, draw, unique_length

EOT = 0


def test_option_rows_are_the_options_inner_prefixes():
    """A row per non-empty proper prefix of an option. The end-of-turn is scored only after an option
    that another one continues ([7] by [7, 8], [7, 8] by [7, 8, 9]); [5], [6, 3] and [7, 8, 9] end
    where no other option goes on, so their end is forced and needs no row."""
    job = OptionJob(suffix=[1, 2], options=[[5], [7], [7, 8], [7, 8, 9], [6, 3]])
    assert job.trie() == {(7,): [1, 2, 3], (7, 8): [2, 3], (6,): [4]}
    assert [list(job.steps(o)) for o in job.options] == [[0], [0, 1], [0, 1, 2], [0, 1, 2], [0, 1]]
    assert job.size == 2 + 3


def test_until_unique_scores_each_option_up_to_where_it_parts_from_the_others():
    """[7, 8, 9] parts from [7, 4] at its second token: 9 is forced, and scored no more; [7] is a prefix of
    both, so it keeps its end-of-turn choice; [5, 3] parts at once."""
    options = [[5, 3], [7], [7, 8, 9], [7, 4]]
    assert [o[:unique_length(o, options)] for o in options] == [[5], [7], [7, 8], [7, 4]]
    alone = [5, 3]
    assert unique_length(alone, [alone]) == 1


def drawn(options, table, temperature, draws=1, seed=0):
    """`draws` draws among `options` (each from its own generator, as the backend draws): `table` maps an
    option-token prefix (the row's context, which stands for the row itself) to {next token: probability}."""
    job = OptionJob(suffix=[1], options=options)
    rows = [[(k, tuple(o[:k])) for k in job.steps(o)] for o in options]

    def logprobs(row: tuple[int, ...], token: int) -> float:
        return math.log(table[row].get(token, 1e-12))

    targets = [o + [EOT] for o in options]
    return [draw(targets, rows, logprobs, temperature, random.Random(seed * 1_000_003 + k)) for k in range(1, draws + 1)]


# "wrist" [5], "wrist link" [5, 8], "sensor" [6]: after 5 the end of turn is a choice against 8.
PREFIX_OPTIONS = [[5], [5, 8], [6]]


def test_greedy_draw_chooses_between_an_option_and_its_continuation():
    ends = {(): {5: 0.9, 6: 0.1}, (5,): {EOT: 0.7, 8: 0.3}}
    goes_on = {(): {5: 0.9, 6: 0.1}, (5,): {EOT: 0.2, 8: 0.8}}
    assert drawn(PREFIX_OPTIONS, ends, 0) == [0]
    assert drawn(PREFIX_OPTIONS, goes_on, 0) == [1]
    assert drawn(PREFIX_OPTIONS, {(): {5: 0.1, 6: 0.9}, (5,): {EOT: 0.5, 8: 0.5}}, 0) == [2]


def test_sampled_draws_follow_the_whole_option_probabilities():
    """At temperature 1 an option is drawn with the product of its steps' probabilities: 0.9 x 0.2,
    0.9 x 0.8 and 0.1."""
    picks = drawn(PREFIX_OPTIONS, {(): {5: 0.9, 6: 0.1}, (5,): {EOT: 0.2, 8: 0.8}}, 1.0, draws=4000)
    shares = [picks.count(i) / len(picks) for i in range(3)]
    assert shares == pytest.approx([0.18, 0.72, 0.10], abs=0.03)


def test_options_that_tokenize_alike_end_the_walk_in_the_first():
    assert drawn([[5, 8], [5, 8], [6]], {(): {5: 0.9, 6: 0.1}, (5,): {8: 1.0}}, 0) == [0]
    assert drawn([[5], [5]], {(): {5: 1.0}}, 1.0, draws=3) == [0, 0, 0]
