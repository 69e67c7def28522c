#!/usr/bin/env python3
"""The book's preprocessor for files outside the book (mdbook runs it at every build).

The chapters show and link files of the repository that live outside `docs/`: the pictures and
3-D pages `spherestep batch --plots` writes into `results/`, the Python examples, and (in the
chapters that include TESTING.md and CHANGELOG.md) links written from the repository's root.
mdbook copies only what is inside its source folder, so each such file is copied into
`docs/_outside/` (ignored by git, remade at every build) and the link rewritten to the copy.
A link that resolves inside the book is left alone; one that resolves nowhere is left alone too
(tests/book.rs reports it as dead in the built HTML).

mdbook's protocol: called with `supports RENDERER` (every renderer is supported), then with the
[context, book] JSON on standard input; the book, rewritten, goes to standard output.
"""

import json
import os
import re
import shutil
import sys

# [text](target) and ![alt](target), the target without spaces (no title is used in this book)
LINK = re.compile(r"(!?\[[^\]]*\]\()([^)\s]+)(\))")
COPIES = "_outside"


def outside_copy(target, chapter_dir, src, repo):
    """The link `target` of a chapter in `chapter_dir` rewritten to a copy inside the book, or
    None when it already resolves inside the book (or nowhere)."""
    if "://" in target or target.startswith(("#", "mailto:", "/")):
        return None
    path, hash_, fragment = target.partition("#")
    if not path:
        return None
    here = os.path.normpath(os.path.join(chapter_dir, path))
    if not os.path.exists(here):
        # written from the repository's root (a file the chapter includes)
        here = os.path.normpath(os.path.join(repo, path))
        if not os.path.exists(here):
            return None
        if here.startswith(src + os.sep):
            return os.path.relpath(here, chapter_dir) + hash_ + fragment
    if here.startswith(src + os.sep) or not here.startswith(repo + os.sep):
        return None
    if not os.path.isfile(here):
        return None
    copy = os.path.join(src, COPIES, os.path.relpath(here, repo))
    os.makedirs(os.path.dirname(copy), exist_ok=True)
    shutil.copyfile(here, copy)
    return os.path.relpath(copy, chapter_dir) + hash_ + fragment


def rewrite(item, src, repo):
    """Rewrites the links of every chapter in `item` (any part of the book's JSON) in place."""
    if isinstance(item, list):
        for x in item:
            rewrite(x, src, repo)
        return
    if not isinstance(item, dict):
        return
    if isinstance(item.get("content"), str) and item.get("path"):
        chapter_dir = os.path.dirname(os.path.join(src, item["path"]))

        def one(m):
            new = outside_copy(m.group(2), chapter_dir, src, repo)
            return m.group(0) if new is None else m.group(1) + new + m.group(3)

        item["content"] = LINK.sub(one, item["content"])
    for v in item.values():
        rewrite(v, src, repo)


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "supports":
        sys.exit(0)
    context, book = json.load(sys.stdin)
    root = os.path.abspath(context["root"])
    src = os.path.normpath(os.path.join(root, context["config"]["book"].get("src", ".")))
    repo = os.path.dirname(root)
    shutil.rmtree(os.path.join(src, COPIES), ignore_errors=True)
    rewrite(book, src, repo)
    json.dump(book, sys.stdout)


if __name__ == "__main__":
    main()
