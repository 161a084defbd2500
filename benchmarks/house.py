"""Facts about the house that anyone can recompute (issue 25): rooms, their sizes, the longest functions, imports
made inside functions, and how many of the package's modules the command line reaches.

    python benchmarks/house.py            # the table, for docs/architecture.md

Nothing here is a test: tests/test_structure.py keeps the rules (layers, no cycles, the notes named).
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

PACKAGE = Path(__file__).resolve().parents[1] / "xcheck"


def modules() -> dict[str, Path]:
    return {p.relative_to(PACKAGE).as_posix(): p for p in sorted(PACKAGE.rglob("*.py")) if "bundled" not in p.parts}


def lines(path: Path) -> int:
    return len(path.read_text().splitlines())


def functions(path: Path):
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            yield node.name, node.end_lineno - node.lineno + 1


def inner_imports(path: Path) -> int:
    tree = ast.parse(path.read_text())
    count = 0
    for node in ast.walk(tree):
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            count += sum(isinstance(n, (ast.Import, ast.ImportFrom)) for n in ast.walk(node)
                         if n is not node and not isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)))
    return count


def package_imports(path: Path) -> set[str]:
    """The xcheck modules ``path`` imports (relative imports resolved to their first two parts)."""
    rel = path.relative_to(PACKAGE).with_suffix("").parts
    package = list(rel[:-1])
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.ImportFrom) and node.level:
            base = package[: len(package) - node.level + 1]
            target = base + (node.module.split(".") if node.module else [])
            names = [target + [a.name] for a in node.names] if not node.module else [target]
            out.update(".".join(t) for t in names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("xcheck."):
            out.add(node.module.removeprefix("xcheck."))
    return out


def main() -> int:
    mods = modules()
    top = [m for m in mods if "/" not in m and m != "__init__.py"]
    packages = sorted({m.split("/")[0] for m in mods if "/" in m})
    sizes = sorted(((lines(p), m) for m, p in mods.items()), reverse=True)
    longest = sorted(((n, f"{m}:{name}") for m, p in mods.items() for name, n in functions(p)), reverse=True)
    cli = mods.get("cli.py")
    print(f"modules: {len(mods)} in {len(packages)} packages ({', '.join(packages)}); at the top of xcheck/: "
          f"{len(top)} modules")
    print(f"lines: {sum(s for s, _ in sizes)}; over 500: " + ", ".join(f"{m} {s}" for s, m in sizes if s > 500))
    print("longest functions: " + ", ".join(f"{name} {n}" for n, name in longest[:6]))
    print(f"imports inside functions: {sum(inner_imports(p) for p in mods.values())} "
          f"(cli.py {inner_imports(cli) if cli else 0})")
    if cli:
        print(f"cli.py: {lines(cli)} lines, imports {len(package_imports(cli))} of the package's modules")
    return 0


if __name__ == "__main__":
    sys.exit(main())
