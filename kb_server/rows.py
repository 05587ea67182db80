"""A SELECT answer as JSON for tools and dialogue: typed values (numbers as numbers) and each column's unit."""
from __future__ import annotations

import re
from collections.abc import Mapping

from urdfkb.kb_server.sparql import Result

NUMBERS = {"integer", "int", "long", "short", "nonNegativeInteger", "positiveInteger", "decimal", "double", "float"}
XSD = "http://www.w3.org/2001/XMLSchema#"
# A data property of the core whose name ends in a unit gives its values in that unit (reachMetres...).
UNIT_SUFFIXES = {"Metres": "m", "Radians": "rad", "Pixels": "px"}
_UNIT_PROPERTY = re.compile(r"core:\w+?(" + "|".join(UNIT_SUFFIXES) + r")\s+\?(\w+)")


def units(text: str) -> dict[str, str]:
    """{column: unit} for the columns a query binds to a core property whose name ends in a unit."""
    return {var: UNIT_SUFFIXES[suffix] for suffix, var in _UNIT_PROPERTY.findall(text)}


def typed(term: Mapping[str, str]) -> object:
    """A SPARQL JSON term as a JSON value: numbers and booleans typed, IRIs and other literals as their text."""
    datatype = term.get("datatype", "")
    value = term["value"]
    if datatype.startswith(XSD) and datatype[len(XSD):] in NUMBERS:
        try:
            number = float(value)
        except ValueError:
            return value
        return int(number) if datatype[len(XSD):] not in ("decimal", "double", "float") and number.is_integer() else number
    if datatype == XSD + "boolean":
        return value in ("true", "1")
    return value


def table(result: Result, unit_of: Mapping[str, str] | None = None) -> dict:
    """A SELECT answer as {columns, rows, units}: one object a row, unbound cells left out."""
    rows = [{var: typed(term) for var, term in row.items()} for row in result.bindings()]
    return {"columns": result.vars, "rows": rows, "units": {c: u for c, u in (unit_of or {}).items() if c in result.vars}}
