"""The imports point one way: grammar/ knows nothing of the checker or the logic,
runtime/ is the standard library alone (generated nodes embed it), and nothing
imports the command line. Every import counts, also those inside functions."""

from __future__ import annotations

import ast
import sys
from pathlib import Path

from conftest import ROOT

PACKAGE = ROOT / "rmvdsl"


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found.add(node.module)
    return found


def _modules(folder: str) -> list[Path]:
    return sorted((PACKAGE / folder).rglob("*.py"))


def test_the_grammar_imports_no_checker_and_no_logic():
    for path in _modules("grammar"):
        bad = {m for m in _imports(path) if m.startswith(("rmvdsl.logic", "rmvdsl.check"))}
        assert not bad, f"{path.relative_to(ROOT)} imports {sorted(bad)}"


def test_the_runtime_is_the_standard_library_alone():
    for path in _modules("runtime"):
        for module in _imports(path):
            top = module.split(".")[0]
            # The registry is data, standard library only too (tested below).
            own = module.startswith("rmvdsl.runtime") or module == "rmvdsl.lang.builtins"
            assert own or (top in sys.stdlib_module_names and top != "rmvdsl"), (
                f"{path.relative_to(ROOT)} imports {module}"
            )


def test_nothing_imports_the_command_line():
    for path in sorted(PACKAGE.rglob("*.py")):
        if path.name == "cli.py":
            continue
        assert "rmvdsl.cli" not in _imports(path), f"{path.relative_to(ROOT)} imports rmvdsl.cli"


def test_the_contracts_catch_a_break(tmp_path: Path):
    """The checker itself: a grammar module that imports the checker is found."""
    bad = tmp_path / "bad.py"
    bad.write_text("def f():\n    from rmvdsl.check import check\n", encoding="utf-8")
    assert "rmvdsl.check" in _imports(bad)


def test_the_registry_is_the_standard_library_alone():
    """rmvdsl.lang.builtins is data that generated nodes embed beside the runtime."""
    for module in _imports(PACKAGE / "lang" / "builtins.py"):
        assert module.split(".")[0] in sys.stdlib_module_names, f"builtins imports {module}"


def test_only_targets_and_the_command_line_read_the_lowering():
    """rmvdsl.ir reads the checker's result; the checker, the grammar, the logic and
    the runtime never import it (the runtime reads rmvdsl.runtime.spec)."""
    for folder in ("grammar", "check", "logic", "runtime"):
        for path in _modules(folder):
            lowering = {m for m in _imports(path) if m == "rmvdsl.ir" or m.startswith("rmvdsl.ir.")}
            assert not lowering, f"{path.relative_to(ROOT)} imports {sorted(lowering)}"


def test_the_language_server_is_a_layer_over_the_workspace():
    """lsp/ reads the checker through rmvdsl.editor.workspace only (thin over the library),
    and nothing below imports lsp/."""
    for path in _modules("editor/lsp"):
        direct = {m for m in _imports(path) if m.startswith(("rmvdsl.check", "rmvdsl.logic"))}
        assert not direct - {"rmvdsl.check.model"}, f"{path.relative_to(ROOT)} imports {direct}"
    for path in sorted(PACKAGE.rglob("*.py")):
        if "lsp" not in path.parts and path.name != "cli.py":  # `rmv lsp` starts it
            assert not any(m.startswith("rmvdsl.editor.lsp") for m in _imports(path)), path


def test_the_host_is_the_runtime_s_and_the_standard_library_s():
    """rmvdsl/host/ is copied into generated packages beside the runtime: it reads
    only the runtime, itself and the standard library; ros2.py alone adds ROS 2,
    ros1.py ROS 1, and ros1_decoding.py rosbags (the ROS 1 nodes' decoder)."""
    extra = {
        "ros2.py": {"rclpy", "diagnostic_msgs", "std_msgs"},
        "ros1.py": {"rospy", "rosgraph", "diagnostic_msgs", "std_msgs"},
        "ros1_decoding.py": {"rosbags"},
    }
    for path in _modules("host"):
        for module in _imports(path):
            top = module.split(".")[0]
            own = module.startswith(("rmvdsl.runtime", "rmvdsl.host"))
            allowed = own or (top in sys.stdlib_module_names and top != "rmvdsl")
            allowed = allowed or top in extra.get(path.name, set())
            assert allowed, f"{path.relative_to(ROOT)} imports {module}"


def test_a_package_carries_the_host_of_its_ros_only():
    """ros1*.py speak ROS 1 and ros2*.py ROS 2: each ROS's package carries its own."""
    from rmvdsl.targets.embed import host_module_for

    assert host_module_for("ros1_graph.py", 1) and not host_module_for("ros1_graph.py", 2)
    assert host_module_for("ros2.py", 2) and not host_module_for("ros2.py", 1)
    assert host_module_for("monitor.py", 1) and host_module_for("monitor.py", 2)


def test_a_target_is_imported_from_its_own_folder_only():
    """Adding a target touches its folder and one line of the registry: no module
    outside rmvdsl/targets/NAME/ imports it (the registry names it as a string)."""
    from rmvdsl.targets import REGISTRY

    found = {}
    for name, module in REGISTRY.items():
        folder = PACKAGE / "targets" / name
        importers = sorted(
            str(path.relative_to(ROOT))
            for path in PACKAGE.rglob("*.py")
            if folder not in path.parents and any(
                m == module or m.startswith(module + ".") for m in _names_imported(path)
            )
        )  # fmt: skip
        if importers:
            found[name] = importers
    assert found == KNOWN_CROSSINGS


# Imports of a target from outside its folder: none.
KNOWN_CROSSINGS: dict[str, list[str]] = {}


def _names_imported(path: Path) -> set[str]:
    """Every module imported, a name imported from a package counted as its module
    (`from rmvdsl.targets import ros2` imports rmvdsl.targets.ros2)."""
    found = _imports(path)
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            found |= {f"{node.module}.{alias.name}" for alias in node.names}
    return found


def test_no_two_modules_import_each_other():
    """No circle of imports between modules, those inside functions included: each
    module's place in the layers is then one place (it was three two-file circles:
    check/fieldpaths and check/types, logic/abstract and logic/sat, replay and its
    report)."""
    import networkx as nx

    modules = {}
    for path in PACKAGE.rglob("*.py"):
        name = ".".join(path.relative_to(ROOT).with_suffix("").parts)
        modules[name.removesuffix(".__init__")] = path
    graph = nx.DiGraph()
    for name, path in modules.items():
        for imported in _names_imported(path):
            if imported in modules and imported != name:
                graph.add_edge(name, imported)
    assert list(nx.simple_cycles(graph)) == []


def test_the_dialects_are_the_standard_library_s():
    """rmvdsl/dialects/ (InfluxQL, TICKscript) is read by targets, importers and
    deploy alike: it knows nothing of the spec, only the standard library and itself."""
    for path in _modules("dialects"):
        for module in _imports(path):
            top = module.split(".")[0]
            own = module.startswith("rmvdsl.dialects")
            assert own or (top in sys.stdlib_module_names and top != "rmvdsl"), (
                f"{path.relative_to(ROOT)} imports {module}"
            )


def test_the_files_the_suite_starts_first_exist():
    """conftest's LONGEST_FIRST orders the suite's files; a renamed one would drop
    out of it silently and start last again."""
    from conftest import LONGEST_FIRST, ROOT

    assert all((ROOT / "tests" / name).is_file() for name in LONGEST_FIRST)
