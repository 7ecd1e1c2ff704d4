#!/usr/bin/env python3
"""Links and figures that cannot rot: every relative link and image in the project's Markdown
resolves, and every figure shown is one `eval` writes.

Usage: check-links.py [ROOT]   (default: the project root, this file's parent's parent)

Checks README.md, CHANGELOG.md, docs/*.md and every crate README:
- a relative link or image `[text](path#anchor)` names a file or folder that exists; an anchor
  names a heading of the target Markdown file (GitHub's slugs: lower case, punctuation dropped,
  spaces to hyphens, repeats numbered) or of the same file;
- an image is one of the figures `eval --docs` copies (`FIGURES` in host-sim/src/eval/docs.rs),
  under docs/figures/, and docs/figures/ holds nothing else.
External links (http, https, mailto) are not fetched. Prints each broken link with its file and
line and exits 1; else prints what it checked.
"""
import os
import re
import sys

ROOT = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), ".."))
LINK = re.compile(r"(!?)\[((?:[^\[\]]|\[[^\]]*\])*)\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
REF = re.compile(r"^\s*\[[^\]]+\]:\s*(\S+)")


def markdown_files():
    files = [os.path.join(ROOT, f) for f in ("README.md", "CHANGELOG.md") if os.path.isfile(os.path.join(ROOT, f))]
    docs = os.path.join(ROOT, "docs")
    if os.path.isdir(docs):
        files += sorted(os.path.join(docs, f) for f in os.listdir(docs) if f.endswith(".md"))
    for d in ("detector-core", "detector-core/dsp", "firmware/board/profiles", "tests/fuzz", "python"):
        p = os.path.join(ROOT, d, "README.md")
        if os.path.isfile(p):
            files.append(p)
    return files


def lines_outside_code(text):
    """(line number, line) of every line outside fenced code blocks."""
    fence = None
    for n, line in enumerate(text.split("\n"), 1):
        s = line.lstrip()
        if fence is None and (s.startswith("```") or s.startswith("~~~")):
            fence = s[:3]
            continue
        if fence is not None:
            if s.startswith(fence):
                fence = None
            continue
        yield n, line


def slug(heading):
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # links: their text
    text = re.sub(r"<[^>]+>", "", text)
    text = text.replace("`", "").replace("*", "")
    text = text.strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


anchors_cache = {}


def anchors(path):
    if path not in anchors_cache:
        seen, out = {}, set()
        with open(path, encoding="utf-8") as f:
            for _, line in lines_outside_code(f.read()):
                m = re.match(r"^(#{1,6})\s+(.*?)\s*#*\s*$", line)
                if not m:
                    continue
                s = slug(m.group(2))
                k = seen.get(s, 0)
                out.add(s if k == 0 else f"{s}-{k}")
                seen[s] = k + 1
        anchors_cache[path] = out
    return anchors_cache[path]


def figures_eval_writes():
    src = os.path.join(ROOT, "host-sim/src/eval/docs.rs")
    with open(src, encoding="utf-8") as f:
        m = re.search(r"pub const FIGURES: \[&str; \d+\] = \[([^\]]*)\];", f.read())
    if not m:
        sys.exit(f"{src}: expected `pub const FIGURES: [&str; N] = [...]`")
    return set(re.findall(r'"([^"]+)"', m.group(1)))


def main():
    shown = figures_eval_writes()
    fig_dir = os.path.join(ROOT, "docs", "figures")
    errors, links, images = [], 0, 0
    for md in markdown_files():
        rel_md = os.path.relpath(md, ROOT)
        with open(md, encoding="utf-8") as f:
            text = f.read()
        outside = list(lines_outside_code(text))
        for i, (n, line) in enumerate(outside):
            # A link's text may wrap onto the next line: match over both, keep what starts here.
            nxt = outside[i + 1][1] if i + 1 < len(outside) and outside[i + 1][0] == n + 1 else ""
            found = [(m.group(1) == "!", m.group(3)) for m in LINK.finditer(line + "\n" + nxt) if m.start() < len(line)]
            r = REF.match(line)
            if r:
                found.append((False, r.group(1)))
            for is_image, target in found:
                if re.match(r"^[a-z][a-z0-9+.-]*:", target, re.I):
                    continue  # http:, https:, mailto:
                links += 1
                path, _, anchor = target.partition("#")
                dest = os.path.normpath(os.path.join(os.path.dirname(md), path)) if path else md
                where = f"{rel_md}:{n}: {target}"
                if not os.path.exists(dest):
                    errors.append(f"{where}: no such file or folder ({os.path.relpath(dest, ROOT)})")
                    continue
                if anchor:
                    if not dest.endswith(".md"):
                        errors.append(f"{where}: an anchor into a file that is not Markdown")
                    elif anchor not in anchors(dest):
                        errors.append(f"{where}: no heading with the anchor #{anchor} in {os.path.relpath(dest, ROOT)}")
                if is_image:
                    images += 1
                    if os.path.dirname(dest) != fig_dir or os.path.basename(dest) not in shown:
                        errors.append(f"{where}: an image that is not one of the figures `eval --docs` writes into docs/figures/ ({', '.join(sorted(shown))})")
    if os.path.isdir(fig_dir):
        for f in sorted(os.listdir(fig_dir)):
            if f not in shown:
                errors.append(f"docs/figures/{f}: not a figure `eval --docs` writes: stale, remove it")
    if errors:
        print("broken links or figures:\n  " + "\n  ".join(errors), file=sys.stderr)
        sys.exit(1)
    print(f"links: {links} relative links and images in {len(markdown_files())} Markdown files resolve; {images} images, all figures eval writes")


main()
