"""Free text a client has the server store (a reviewer's name, a model name): one line of printable text;
and errors, cut to a few KiB before they are kept or logged.

XML 1.0 cannot carry most control characters (not even escaped), U+FFFE or U+FFFF, nor UTF-8 a lone
surrogate (which JSON's "\\ud800" makes): stored, one would make the robot's .owl export ill-formed or
answer 500. Such text is refused, naming the field, as is any other control character (line breaks,
C1 controls) and any format character (Unicode category Cf: the bidi overrides and isolates U+202A-U+202E
and U+2066-U+2069 make a name display as another; also the zero-width joiners U+200C and U+200D, which
some scripts and emoji sequences use): a name needs none.
"""
from __future__ import annotations

import re
from collections.abc import Iterable

from urdfkb.pipeline.reading.ingest import format_character
from urdfkb.settings import MAX_ERROR

_UNSTORABLE = re.compile("[\x00-\x1f\x7f-\x9f\ud800-\udfff\ufffe\uffff]")


def check_text(field: str, value: str) -> str:
    """`value` if it holds no control or format character, lone surrogate, U+FFFE or U+FFFF; ValueError naming
    `field` otherwise."""
    match = _UNSTORABLE.search(value)
    if (bad := match.group() if match else format_character(value)) is not None:
        raise ValueError(f"{field} must be text without control characters, format characters (bidi, zero-width) "
                         f"or lone surrogates (found U+{ord(bad):04X})")
    return value


def cut(text: str, limit: int = MAX_ERROR) -> str:
    """`text`, or its first `limit` characters and how long it was: an error kept or logged (a xacro's can
    run to megabytes) stays a few KiB."""
    if len(text) <= limit:
        return text
    return f"{text[:limit]}... [cut: {len(text):,} characters in all]"


def listed(names: Iterable[object], limit: int = 5) -> str:
    """The first `limit` of `names` joined by commas, with how many more there are: an error naming what a
    request got wrong stays short however much it got wrong."""
    names = list(names)
    shown = ", ".join(cut(str(n), 100) for n in names[:limit])
    return shown + (f" and {len(names) - limit:,} more" if len(names) > limit else "")
