"""The documentation site's pages hold what the code does: every scenario key, every command, a working tutorial."""

from __future__ import annotations

import argparse
import ast
import importlib.util
import json
import re
import shlex
import tomllib
import warnings
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

import bracekit
from bracekit.cli.main import build_parser, main
from bracekit.simulation import scenario as scenario_module
from bracekit.simulation.scenario import load_scenario, parse_scenario, shipped_scenarios
from bracekit.viewer import load_scene

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
FENCE = re.compile(r"^```(\w+)([^\n]*)\n(.*?)^```", re.S | re.M)


def _blocks(page: str, language: str) -> list[tuple[str, str]]:
    """(title or '', body) of every fenced block of `language` on a docs page."""
    text = (DOCS / page).read_text(encoding="utf-8")
    out = []
    for lang, attrs, body in FENCE.findall(text):
        if lang == language:
            title = re.search(r'title="([^"]+)"', attrs)
            out.append((title.group(1) if title else "", body))
    return out


def _sections(page: str) -> dict[str, str]:
    """Heading text → the text below it (up to the next heading of level 2 or 3)."""
    text = (DOCS / page).read_text(encoding="utf-8")
    parts = re.split(r"^#{2,3} (.+)$", text, flags=re.M)
    return {parts[i].strip(): parts[i + 1] for i in range(1, len(parts) - 1, 2)}


# --- the scenario reference -----------------------------------------------------------------------
def _allowed_keys() -> dict[str, tuple[str, ...]]:
    """Table path ('' for the top level) → the keys scenario.py allows there, read from its `_Table` calls.

    The tables are found in the source: `_Table(data, "", (...))`, `x = parent.table("name", (...))` and
    `parent.table("name", NAME)` / `weight_keys()`; every `_Table(...)` and `.table(...)` call must be understood,
    so that a new table cannot slip past this test.
    """
    tree = ast.parse(Path(scenario_module.__file__).read_text(encoding="utf-8"))
    paths: dict[str, str] = {"top": ""}  # variable → table path
    keys: dict[str, tuple[str, ...]] = {}
    unresolved: list[str] = []

    def allowed(node: ast.expr) -> tuple[str, ...] | None:
        if isinstance(node, ast.Tuple) and all(isinstance(e, ast.Constant) for e in node.elts):
            return tuple(str(e.value) for e in node.elts)  # type: ignore[attr-defined]
        if isinstance(node, ast.Name):
            return tuple(getattr(scenario_module, node.id))
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name):
            return tuple(getattr(scenario_module, node.func.id)())
        return None

    inside = {  # the _Table class's own method `table` builds the tables the calls below name
        id(n) for c in tree.body if isinstance(c, ast.ClassDef) and c.name == "_Table" for n in ast.walk(c)
    }
    calls: list[tuple[ast.Call, str | None]] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Assign) and isinstance(node.value, ast.Call) and len(node.targets) == 1:
            target = node.targets[0]
            calls.append((node.value, target.id if isinstance(target, ast.Name) else None))
    assigned = {id(c) for c, _ in calls}
    calls += [(n, None) for n in ast.walk(tree) if isinstance(n, ast.Call) and id(n) not in assigned]
    calls = [(c, v) for c, v in calls if id(c) not in inside]
    pending = list(calls)
    for _ in range(5):  # parents before children, whatever the source order
        left = []
        for call, var in pending:
            func = call.func
            if isinstance(func, ast.Name) and func.id == "_Table":
                path_node = call.args[1]
                if isinstance(path_node, ast.Constant):
                    path = str(path_node.value)
                elif isinstance(path_node, ast.JoinedStr):  # f"brace[{i}]": the items of [[brace]]
                    path = "brace"
                else:
                    unresolved.append(ast.unparse(call))
                    continue
            elif isinstance(func, ast.Attribute) and func.attr == "table" and isinstance(func.value, ast.Name):
                if func.value.id not in paths:
                    left.append((call, var))
                    continue
                parent, name = paths[func.value.id], call.args[0]
                assert isinstance(name, ast.Constant), ast.unparse(call)
                path = f"{parent}.{name.value!s}" if parent else str(name.value)
            else:
                continue
            found = allowed(call.args[2] if isinstance(func, ast.Name) else call.args[1])
            if found is None:
                unresolved.append(ast.unparse(call))
                continue
            keys[path] = tuple(dict.fromkeys(keys.get(path, ()) + found))
            if var is not None:
                paths[var] = path
        pending = left
    assert not unresolved and not pending, (unresolved, [ast.unparse(c) for c, _ in pending])
    return keys


def test_the_source_reading_finds_every_table() -> None:
    keys = _allowed_keys()
    assert set(keys) == {
        "",
        "robot",
        "brace",
        "task",
        "start",
        "compliance",
        "gradient_projection",
        "gradient_projection.weights",
        "simulation",
        "loads",
    }
    assert keys["brace"] == scenario_module.BRACE_KEYS
    assert keys["gradient_projection.weights"] == scenario_module.weight_keys()
    # the reading agrees with the parser: each key found is accepted where it was found, an unknown one is not
    with pytest.raises(bracekit.InputError, match=re.escape("unknown key 'task.no_such_key'")):
        data = tomllib.loads(shipped_scenarios()["paper"].read_text(encoding="utf-8"))
        data["task"]["no_such_key"] = 1
        parse_scenario(data)


def test_scenario_reference_documents_every_key() -> None:
    sections = _sections("scenarios.md")
    missing = []
    for path, allowed in _allowed_keys().items():
        title = "Top level" if not path else f"`[{path}]`"
        assert title in sections, f"docs/scenarios.md has no section {title}"
        rows = {m.group(1) for m in re.finditer(r"^\| `([^`]+)` \|", sections[title], flags=re.M)}
        missing += [f"{path or 'top level'}: {key}" for key in allowed if key not in rows]
    assert not missing, f"keys not documented in docs/scenarios.md: {missing}"


@pytest.mark.parametrize("index", range(len(_blocks("scenarios.md", "toml"))))
def test_scenario_reference_examples_parse(index: int) -> None:
    """Each example replaces its tables in the paper's scenario, and the result is a valid scenario."""
    data = tomllib.loads(shipped_scenarios()["paper"].read_text(encoding="utf-8"))
    example = tomllib.loads(_blocks("scenarios.md", "toml")[index][1])
    if isinstance(example.get("brace"), list):  # several braces: the one-brace weights do not apply
        data["gradient_projection"].pop("weights")
    data.update(example)
    sc = parse_scenario(data)
    for table, values in example.items():
        if table == "task":
            assert type(sc.task).__name__.lower() == ("waypoints" if values["type"] == "line" else values["type"])
            assert sc.task_space.kind == values.get("space", "pose")
        if table == "brace":
            assert len(sc.braced.braces) == (len(values) if isinstance(values, list) else 1)
        if table == "loads":
            assert sc.holding.wrenches is not None and len(sc.holding.wrenches) == len(values["wrenches"])


# --- the CLI reference ----------------------------------------------------------------------------
def _hooks() -> ModuleType:
    spec = importlib.util.spec_from_file_location("docs_hooks", DOCS / "hooks.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_cli_reference_has_every_command_help() -> None:
    hooks = _hooks()
    assert hooks.CLI_MARKER in (DOCS / "cli.md").read_text(encoding="utf-8")
    page = hooks.cli_reference()
    parser = build_parser()
    (action,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    names: dict[str, argparse.ArgumentParser] = dict(action.choices)
    assert len(names) >= 5
    for name in names:
        assert f"## `bracekit {name}`" in page
        for option in re.findall(r"--[a-z][a-z-]+", names[name].format_usage()):
            assert option in page.split(f"## `bracekit {name}`")[1].split("\n## ")[0], (name, option)


def test_api_index_names_every_public_name() -> None:
    text = (DOCS / "api" / "index.md").read_text(encoding="utf-8")
    missing = [name for name in bracekit.__all__ if f"`{name}`" not in text]
    assert not missing, f"docs/api/index.md does not list {missing}"


def test_index_python_runs() -> None:
    (code,) = [body for _, body in _blocks("index.md", "python")]
    exec(compile(code, "docs/index.md", "exec"), {})


# --- the tutorial ---------------------------------------------------------------------------------
def _tutorial_commands() -> list[list[str]]:
    commands = []
    for _, body in _blocks("tutorial.md", "bash"):
        for line in body.replace("\\\n", " ").splitlines():  # continued lines joined
            if line.startswith("bracekit "):
                commands.append(shlex.split(line)[1:])
    return commands


def test_tutorial_works_as_printed(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: Any) -> None:
    files = {title: body for lang in ("xml", "toml") for title, body in _blocks("tutorial.md", lang) if title}
    assert set(files) == {"arm8.urdf", "arm8.toml"}
    for name, body in files.items():
        (tmp_path / name).write_text(body, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    sc = load_scenario("arm8.toml")
    assert sc.robot.n == 8 and sc.braced.split.n1 == 5

    commands = _tutorial_commands()
    assert [c[0] for c in commands] == ["study", "evaluate", "run", "view", "validate"]
    outputs: dict[str, str] = {}
    for argv in commands:
        if argv[0] == "run":
            argv = [*argv, "--no-figures", "--quiet"]  # the figures are tested with the report
        if argv[0] == "view":  # serving is tested in tests/viewer; here: the command parses, the folder loads
            args = build_parser().parse_args(argv)
            assert load_scene(args.out_dir).name == sc.name
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            code = main(argv)
        outputs[argv[0]] = capsys.readouterr().out
        assert code == 0, (argv, outputs[argv[0]])

    # the output the tutorial quotes: study's and evaluate's lines verbatim, validate's constrained row
    study, evaluate, validate = (body for _, body in _blocks("tutorial.md", "text"))
    for line in study.strip().splitlines():
        assert line in outputs["study"], line
    for line in evaluate.strip().splitlines():
        assert line in outputs["evaluate"], line
    (row,) = [line for line in validate.splitlines() if line.startswith("constrained")]
    (got,) = [line for line in outputs["validate"].splitlines() if line.startswith("constrained")]
    quoted = [float(x) for x in re.findall(r"([0-9.]+) %", row)]
    measured = [float(x) for x in re.findall(r"([0-9.]+) %", got)]
    assert measured == pytest.approx(quoted, rel=0.05, abs=0.01)

    # the table of mean C_i in the tutorial is the run's
    summary = json.loads((tmp_path / "arm8-out" / "summary.json").read_text(encoding="utf-8"))
    labels = {
        "free space min. norm": "free_space_min_norm",
        "braced min. norm": "braced_min_norm",
        "braced grad. projection": "braced_gradient_projection",
    }
    doc = (DOCS / "tutorial.md").read_text(encoding="utf-8")
    for label, key in labels.items():
        found = re.search(rf"^\| {re.escape(label)} \| ([0-9.]+) \| (yes|no) \| ([0-9.]+) m \|", doc, flags=re.M)
        assert found is not None, label
        run = summary["strategies"][key]
        assert float(found.group(1)) == pytest.approx(run["Ci_mean"], abs=5e-6)
        assert (found.group(2) == "yes") == run["completed"]
        assert float(found.group(3)) == pytest.approx(run["min_link_clearance_m"], abs=5e-4)

    (snippet,) = [body for _, body in _blocks("tutorial.md", "python")]
    exec(compile(snippet, "docs/tutorial.md", "exec"), {})
    assert "mean C_i" in capsys.readouterr().out


def test_no_control_characters_in_the_docs() -> None:
    """A formula written through a non-raw Python string loses its backslashes (\\t, \\f, \\b become controls)."""
    bad = []
    for path in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
            if re.search(r"[\x00-\x08\x0b\x0c\x0e-\x1f]", line):
                bad.append(f"{path.relative_to(ROOT)}:{number}")
    assert not bad, "control characters in: " + ", ".join(bad)
