#!/usr/bin/env python3
"""The README's command reference against the command itself (ctest entry `docs`).

For every subcommand of `minv --help`, the options its `--help` prints must be exactly the
options the README's block under "## The `minv` command" lists for it, and the README may list
no subcommand the command lacks. Usage: docs_test.py MINV README.md"""
import re
import subprocess
import sys


def help_options(minv, words):
    out = subprocess.run([minv, *words, "--help"], capture_output=True, text=True, check=True)
    return set(re.findall(r"(?<![\w-])--[a-z][a-z-]*", out.stdout)) - {"--help"}


def subcommands(minv, words):
    """The subcommands of `minv WORDS --help` (CLI11 lists them under "Subcommands:")."""
    out = subprocess.run([minv, *words, "--help"], capture_output=True, text=True,
                         check=True).stdout
    out = out.replace("Subcommands:", "SUBCOMMANDS:")
    if "SUBCOMMANDS:" not in out:
        return []
    block = out.split("SUBCOMMANDS:", 1)[1]
    return [m.group(1) for m in re.finditer(r"^\s{2}(\w[\w-]*)\s", block, re.M)]


def readme_reference(path):
    """{("solve",): {"--model", …}, ("experiment", "flops"): {…}, …} from the README block."""
    text = open(path, encoding="utf-8").read()
    section = text.split("## The `minv` command", 1)[1]
    block = section.split("```sh", 1)[1].split("```", 1)[0]
    ref, current = {}, None
    for line in block.splitlines():
        m = re.match(r"\s*build/minv((?: [a-z][a-z-]*)+)", line)
        if m:
            current = tuple(m.group(1).split())
            ref.setdefault(current, set())
        if current is not None:
            ref[current] |= set(re.findall(r"(?<![\w-])--[a-z][a-z-]*", line))
    return ref


def main():
    minv, readme = sys.argv[1], sys.argv[2]
    ref = readme_reference(readme)
    commands = []
    for sub in subcommands(minv, []):
        nested = subcommands(minv, [sub])
        commands += [(sub, n) for n in nested] if nested else [(sub,)]
    problems = []
    for cmd in commands:
        have = help_options(minv, list(cmd))
        if cmd not in ref:
            problems.append(f"README lacks `minv {' '.join(cmd)}`")
            continue
        if ref[cmd] != have:
            problems.append(f"`minv {' '.join(cmd)}`: --help has {sorted(have - ref[cmd])} that "
                            f"the README lacks; the README has {sorted(ref[cmd] - have)} that "
                            "--help lacks")
    for cmd in ref:
        if cmd not in commands:
            problems.append(f"README lists `minv {' '.join(cmd)}`, which the command lacks")
    for p in problems:
        print("docs:", p)
    print(f"docs: {len(commands)} subcommands checked, {len(problems)} problems")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
