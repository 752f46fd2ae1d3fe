#!/usr/bin/python3
"""Fails on any path a document names that does not exist.

Reads the Markdown files given (folders: every *.md below them, except build trees) and
checks every repository path they name: a Markdown link's target (relative to the
document's folder) and every `code span` that looks like a path from the repository's root
(it starts with one of the project's top-level folders, or is a top-level file). Paths that
the build or a run makes (build*/, scenes/generated/, out/), placeholders (<...>, {...},
N, globs) and URLs are not checked. Prints `FILE:LINE: PATH does not exist` for each and
exits 1 when there is one.

Usage: check_doc_paths.py ROOT [DOC_OR_FOLDER ...]   (default: README.md, docs, bench, scenes,
       scripts, python, tests/fuzz below ROOT)
"""
import pathlib
import re
import sys

TOP = ("src/", "kernels/", "tests/", "bench/", "scripts/", "docs/", "scenes/", "python/",
       ".ci/", "papers/", "cmake/")
MADE = ("build", "scenes/generated/", "out/", "papers/out/")


def candidates(text):
    """(line, path, relative_to_doc) for each path-like reference in a Markdown text."""
    in_fence = False
    for n, line in enumerate(text.splitlines(), 1):
        if line.lstrip().startswith("```"):
            in_fence = not in_fence
            continue
        if in_fence:
            continue
        for m in re.finditer(r"\]\(([^)\s]+)\)", line):
            target = m.group(1).split("#")[0]
            if target and not re.match(r"^[a-z]+:", target):
                yield n, target, True
        for m in re.finditer(r"`([^`\s]+)`", line):
            token = m.group(1).rstrip(".,:;")
            if token.startswith(TOP) or re.fullmatch(r"[A-Za-z_.-]+\.(md|txt|toml|cfg)", token):
                yield n, token, False


def placeholder(path):
    return bool(re.search(r"[<>{}*?$]|\bN\b|\.\.\.|…", path)) or path.startswith(MADE)


def check(root, doc):
    dead = []
    for n, path, relative in candidates(doc.read_text(encoding="utf-8")):
        if placeholder(path):
            continue
        clean = re.sub(r":\d+(-\d+)?$", "", path)  # file:line
        base = doc.parent if relative else root
        if not (base / clean).exists() and not (relative and (root / clean).exists()):
            dead.append(f"{doc.relative_to(root)}:{n}: {path} does not exist")
    return dead


def main():
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else ".").resolve()
    names = sys.argv[2:] or ["README.md", "docs", "bench", "scenes", "scripts", "python",
                             "tests/fuzz"]
    docs = []
    for name in names:
        p = root / name
        if p.is_dir():
            docs += [d for d in sorted(p.rglob("*.md"))
                     if not any(part.startswith("build") for part in d.relative_to(root).parts)]
        elif p.exists():
            docs.append(p)
    dead = [line for d in docs for line in check(root, d)]
    for line in dead:
        print(line)
    print(f"{len(docs)} documents, {len(dead)} dead paths")
    return 1 if dead else 0


if __name__ == "__main__":
    sys.exit(main())
