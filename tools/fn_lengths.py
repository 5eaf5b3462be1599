#!/usr/bin/env python3
"""Functions longer than N lines in a Rust source tree, longest first, and their count.

Usage: tools/fn_lengths.py [DIR] [N]   (defaults: src 50)

A function runs from its `fn` line to the closing brace at its own indentation. Test code is left
out: files named tests.rs and everything after a top-level `#[cfg(test)]`.
"""
import os
import re
import sys

FN = re.compile(r"^(\s*)(pub(\([^)]*\))?\s+)?(const\s+)?(unsafe\s+)?fn\s+(\w+)")


def lengths(root):
    for dirpath, _, files in os.walk(root):
        for f in files:
            if not f.endswith(".rs") or f == "tests.rs":
                continue
            path = os.path.join(dirpath, f)
            lines = open(path, encoding="utf-8").read().split("\n")
            if "#[cfg(test)]" in lines:
                lines = lines[: lines.index("#[cfg(test)]")]
            for i, line in enumerate(lines):
                m = FN.match(line)
                if not m or line.rstrip().endswith(";"):
                    continue
                indent = " " * len(m.group(1))
                j = i + 1
                while j < len(lines) and not (lines[j].startswith(indent + "}") and lines[j][len(indent) + 1 : len(indent) + 2] in ("", " ", ";", ",", ")")):
                    j += 1
                yield j - i + 1, path, i + 1, m.group(6)


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "src"
    limit = int(sys.argv[2]) if len(sys.argv) > 2 else 50
    long = sorted((r for r in lengths(root) if r[0] > limit), reverse=True)
    for n, path, line, name in long:
        print(f"{n:4d} {path}:{line} {name}")
    print(f"{len(long)} functions over {limit} lines")


if __name__ == "__main__":
    main()
