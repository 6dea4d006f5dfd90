"""Load-case set files: a base case, load cases with their weights, seeds and overrides.

:func:`load_loadset` reads a set file (TOML, keys in :data:`LOADSET_KEYS`, docs/loadsets.md)
and refuses every problem at once with a :class:`~cablefem.errors.CaseError` naming the key,
before any case runs: the set's own keys (:class:`~cablefem.case.reader.Reader`), every
override's path in the base case, and every case and seed parsed in full
(:func:`~cablefem.case.parse.parse_case`), so that a bad override value is refused too.

Overrides are dotted paths into the base case's tables: ``"fluid.current"``,
``"dynamics.t_end"``; in an array of tables an item is reached by its ``name`` (or, for
items without one, its index from 0): ``"anchors.deck.motion.amplitude"``,
``"fluid.waves.0.height"``. The key must exist in the base case file (a default is not
enough: write it in the base case). Seeds: seed ``k`` (0, 1, ...) adds ``k`` to every
``seed`` key of the case (each table whose schema has a ``seed`` key: the key's value in
the case file, or its default); a case with ``seeds > 1`` must have such a table.
Pure Python: no dolfinx.
"""

from __future__ import annotations

import copy
import json
import os
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

from cablefem.case.keys import CASE_KEYS, NETWORK_KEYS, REQUIRED, KeyDoc, TableDoc
from cablefem.case.parse import parse_case
from cablefem.case.reader import Reader
from cablefem.errors import CaseError

__all__ = ["LOADSET_KEYS", "LoadCase", "LoadSet", "load_loadset", "format_loadset_reference",
           "case_dict", "case_text"]

LOADSET_KEYS: dict = {
    "base": KeyDoc("string", REQUIRED, "", "The base case file (TOML), relative to the set "
                   "file; every load case is it with its overrides."),
    "design_life": KeyDoc("number", REQUIRED, "years", "Design life, > 0: the fatigue "
                          "damage is summed over it."),
    "total_hours": KeyDoc("number", None, "h/year", "Hours per year that the cases' "
                          "probabilities refer to (e.g. 8766 for the whole year), > 0; "
                          "required when a case gives a probability."),
    "extreme_duration": KeyDoc("number", None, "s", "Duration of the most probable maxima "
                               "of the extremes, > 0; default: each case's statistics "
                               "window."),
    "cases": TableDoc("array of tables", REQUIRED, "", "The load cases ([[cases]]), at "
                      "least one.", {
        "name": KeyDoc("string", REQUIRED, "", "The case's name, unique; its folder "
                       "(characters A-Z a-z 0-9 _ - .)."),
        "hours": KeyDoc("number", None, "h/year", "Its weight: hours per year, > 0 (or "
                        "give probability)."),
        "probability": KeyDoc("number", None, "-", "Its weight as a probability, > 0 and "
                              "<= 1, of total_hours (hours = probability * total_hours)."),
        "seeds": KeyDoc("integer", 1, "-", "Number of seeds, >= 1: seed k (0 .. seeds-1) "
                        "adds k to every seed key of the case (docs/loadsets.md)."),
        "overrides": KeyDoc("table", None, "", "Base-case keys set for this case, as "
                            "dotted keys in quotes: \"fluid.current\" = [...], "
                            "\"anchors.deck.motion.amplitude\" = 0.1 (an array-of-tables "
                            "item by its name, or its index from 0)."),
    }),
}

NAME = re.compile(r"[A-Za-z0-9_.-]+")


@dataclass
class LoadCase:
    """One load case of a set: its weight (h/year), seeds and the case dict of each seed."""

    name: str
    hours_per_year: float
    seeds: int
    overrides: dict = field(default_factory=dict)
    cases: list = field(default_factory=list)  #: per seed: the case dict (JSON-able)


@dataclass
class LoadSet:
    """A validated load-case set (:func:`load_loadset`)."""

    source: str
    base: Path
    design_life: float
    extreme_duration: float | None
    cases: list[LoadCase]
    t_end: float | None = None

    @property
    def runs(self) -> list[tuple[int, int]]:
        """Every (case index, seed) in order: the batch's queue."""
        return [(i, k) for i, c in enumerate(self.cases) for k in range(c.seeds)]


def _walk(data: dict, path: str) -> tuple[object, object, str | None]:
    """The container and key ``path`` reaches in ``data``, or a problem."""
    parts = path.split(".")
    node: object = data
    for i, part in enumerate(parts):
        where = ".".join(parts[:i]) or "the top level"
        if isinstance(node, list):
            names = [item.get("name") if isinstance(item, dict) else None for item in node]
            if part in names:
                idx = names.index(part)
            elif part.isdigit() and int(part) < len(node):
                idx = int(part)
            else:
                return None, None, (f"{where} has no item named or numbered {part!r} "
                                    f"(names: {', '.join(str(n) for n in names if n)})")
            key: object = idx
        elif isinstance(node, dict):
            if part not in node:
                return None, None, (f"the base case has no key {part!r} in {where} (write "
                                    "it in the base case to override it)")
            key = part
        else:
            return None, None, f"{where} is a value, not a table"
        if i == len(parts) - 1:
            return node, key, None
        node = node[key]  # type: ignore[index]
    return None, None, "empty key"


def _seed_tables(data: dict, doc: dict) -> list[dict]:
    """The tables of ``data`` (with their docs) whose schema has a ``seed`` key."""
    out = []
    for key, value in data.items():
        d = doc.get(key)
        if not isinstance(d, TableDoc):
            continue
        for item in value if isinstance(value, list) else [value]:
            if isinstance(item, dict):
                out += _seed_tables(item, d.keys)
                if isinstance(d.keys.get("seed"), KeyDoc):
                    out.append((item, d.keys["seed"].default))
    return out


def case_dict(base: dict, overrides: dict, seed: int, t_end: float | None = None) -> dict:
    """The case of one seed: ``base`` with ``overrides`` (validated paths), every seed key
    shifted by ``seed``, and ``dynamics.t_end`` set to ``t_end`` when given."""
    data = copy.deepcopy(base)
    for path, value in overrides.items():
        node, key, _ = _walk(data, path)
        node[key] = copy.deepcopy(value)  # type: ignore[index]
    doc = NETWORK_KEYS if "network" in data else CASE_KEYS
    for table, default in _seed_tables(data, doc):
        value = table.get("seed", default)
        if isinstance(value, int) and not isinstance(value, bool):
            table["seed"] = value + seed
    if t_end is not None and isinstance(data.get("dynamics"), dict):
        data["dynamics"]["t_end"] = float(t_end)
    return data


def _read_toml(path: Path, what: str) -> dict:
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise CaseError([("file", f"cannot read the {what}: {exc.strerror or exc}")],
                        str(path)) from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise CaseError([("TOML syntax", f"not a valid TOML file: {exc}")],
                        str(path)) from None


def _load_case_entry(r: Reader, problems: list, total: float | None, seen: set):
    name = r.string("name")
    if name is not None and not NAME.fullmatch(name):
        r.add("name", f"must use only the characters A-Z a-z 0-9 _ - ., got {name!r}")
        name = None
    elif name is not None and name in seen:
        r.add("name", f"duplicate case name {name!r}")
        name = None
    seen.add(name)
    hours = r.number("hours", gt=0) if r.has("hours") else None
    if r.has("probability"):
        p = r.number("probability", gt=0, le=1)
        if r.has("hours"):
            r.add("probability", "give hours or probability, not both")
        elif total is None:
            r.add("probability", "needs total_hours at the top level (hours per year "
                                 "that the probabilities refer to)")
        elif p is not None:
            hours = p * total
    elif not r.has("hours"):
        r.add("hours", "missing: give hours (per year) or probability")
    seeds = r.integer("seeds", ge=1)
    overrides, _ = r.raw("overrides")
    if overrides is None:
        overrides = {}
    if not isinstance(overrides, dict):
        r.add("overrides", "expected a table of dotted keys and values")
        overrides = {}
    return name, hours, seeds, overrides


def load_loadset(path: str | os.PathLike, *, t_end: float | None = None,
                 overrides: dict | None = None) -> LoadSet:
    """Read and validate a load-case set file (see the module docstring).

    Args:
        path: The set file (TOML).
        t_end: The run's end (s) for every case (``--t-end``), else each case's own.
        overrides: Dotted keys set in every case after its own overrides (e.g. a shorter
            statistics window for a quick look), validated as theirs are.

    Raises:
        CaseError: Every problem of the set, its overrides and its cases, by key.
    """
    path = Path(path)
    overrides_all = overrides
    data = _read_toml(path, "load-case set file")
    problems: list = []
    top = Reader(data, "", LOADSET_KEYS, problems)
    base_name = top.string("base", path=True)
    life = top.number("design_life", gt=0)
    total = top.number("total_hours", gt=0)
    extreme = top.number("extreme_duration", gt=0)
    entries = top.tables("cases")
    if "cases" in data and not entries and not problems:
        problems.append(("cases", "expected at least one [[cases]] table"))
    seen: set = set()
    parsed = [_load_case_entry(r, problems, total, seen) for r in entries]
    base = path.parent / base_name if base_name is not None else None
    base_data = None
    if base is not None:
        try:
            base_data = _read_toml(base, "base case file")
        except CaseError as err:
            problems += [(f"base ({k})", m) for k, m in err.problems]
    cases = []
    if base_data is not None:
        for i, (name, hours, seeds, own) in enumerate(parsed):
            extra = overrides_all or {}
            overrides = {**own, **extra}
            bad = False
            for key in overrides:
                _, _, why = _walk(base_data, str(key))
                if why:
                    where = "overrides" if key in extra and key not in own else \
                        f"cases[{i}].overrides"
                    problems.append((f"{where}.{key}", why))
                    bad = True
            if bad or name is None or seeds is None:
                continue
            probe = case_dict(base_data, overrides, 0)
            doc = NETWORK_KEYS if "network" in probe else CASE_KEYS
            if seeds > 1 and not _seed_tables(probe, doc):
                problems.append((f"cases[{i}].seeds", f"{seeds} seeds, but the case has "
                                 "no seeded input (no table with a seed key, such as "
                                 "[fluid.spectrum]): every seed would be the same run"))
                continue
            dicts = [case_dict(base_data, overrides, k, t_end) for k in range(seeds)]
            for k, d in enumerate(dicts):
                try:
                    parse_case(d, base_dir=base.parent, source=str(base))
                except CaseError as err:
                    problems += [(f"cases[{i}] ({name}, seed {k}): {key}", m)
                                 for key, m in err.problems]
            cases.append(LoadCase(name, hours, seeds, dict(overrides), dicts))
    if problems:  # an override of every case is reported once
        raise CaseError(list(dict.fromkeys(problems)), str(path))
    return LoadSet(str(path), base, life, extreme, cases, t_end)


def case_text(data: dict) -> str:
    """The JSON text a batch writes as a case's ``case.json`` (sorted keys: the same case
    gives the same text, whose SHA-256 the checkpoint keeps)."""
    return json.dumps(data, sort_keys=True, indent=1) + "\n"


def format_loadset_reference(markdown: bool = False) -> str:
    """The set file's keys as text (``cablefem keys --loadset``) or a Markdown table."""
    rows = []

    def walk(doc: dict, prefix: str) -> None:
        for key, d in doc.items():
            default = "required" if d.default is REQUIRED else (
                "" if d.default is None else repr(d.default))
            rows.append((prefix + key, d.type, d.unit, default, d.help))
            if isinstance(d, TableDoc):
                walk(d.keys, f"{prefix}{key}[].")

    walk(LOADSET_KEYS, "")
    if markdown:
        lines = ["| key | type | unit | default | meaning |", "|---|---|---|---|---|"]
        lines += [f"| `{k}` | {t} | {u} | {d} | {h} |" for k, t, u, d, h in rows]
        return "\n".join(lines)
    return "\n".join(f"{k} ({t}{', ' + u if u else ''}{'; ' + d if d else ''}): {h}"
                     for k, t, u, d, h in rows)
