"""The one writer of a generated section of a markdown file (docs/results.md): the lines between
`<!-- NAME:begin -->` and `<!-- NAME:end -->` are replaced, or appended under `## TITLE` when
the markers are absent. Used by the bench scripts."""
import os
import re
import subprocess

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def commit_stamp():
    """The checkout's short commit, which a generated section names."""
    return subprocess.run(["git", "-C", REPO, "rev-parse", "--short", "HEAD"],
                          stdout=subprocess.PIPE, text=True).stdout.strip()


def write_section(path, name, title, lines):
    begin, end = f"<!-- {name}:begin -->", f"<!-- {name}:end -->"
    text = open(path).read() if os.path.exists(path) else ""
    block = begin + "\n" + "\n".join(lines) + "\n" + end
    if begin in text and end in text:
        text = re.sub(re.escape(begin) + ".*?" + re.escape(end), lambda m: block, text, flags=re.S)
    else:
        text = text.rstrip() + f"\n\n## {title}\n\n" + block + "\n"
    with open(path, "w") as f:
        f.write(text)
