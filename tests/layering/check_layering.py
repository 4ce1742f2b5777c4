#!/usr/bin/env python3
"""Fails on an #include that breaks the layering of docs/architecture.md.

Every .h and .cc under the product folders is read; each `#include "<folder>/..."` must
name the file's own folder or one the table below allows. The offending file:line is
printed with the rule it breaks. Tests and benchmarks are not product code and are not
checked: they may include any layer.

  check_layering.py [SOURCE_DIR]   check the tree (default: two folders up from this file)
  check_layering.py --self-test    prove the checker fails on bad trees and passes a good one
"""
import os
import re
import sys
import tempfile

# What each product folder may include besides itself, bottom up. Keep this in step with
# docs/architecture.md: a new edge is a design decision, made there first.
MIDDLE = ("acquisition", "compensation", "storage", "nc_out")
ALLOWED = {
    "core": set(),
    "acquisition": {"core"},
    "compensation": {"core"},
    "storage": {"core"},
    "nc_out": {"core"},
    # Apart from the stack: the virtual grinder needs the wheel path and the table writers.
    "simulator": {"core", "compensation", "nc_out"},
    "report": {"core", "compensation", "storage"},
    # The plant: the outbox sender (MQTT) and the central history (PostgreSQL).
    "plant": {"core", "storage", "report"},
    "job": {"core", *MIDDLE, "report"},
    "config": {"core", *MIDDLE, "report", "plant", "job"},
    "service": {"core", *MIDDLE, "report", "plant", "job", "config"},
    "cli": {"core", *MIDDLE, "simulator", "report", "plant", "job", "config", "service"},
}
ORDER = ["core", *MIDDLE, "simulator", "report", "plant", "job", "config", "service", "cli"]

# Includes that break the rules today and are being removed. Each entry is reported, but
# does not fail the check; an entry that no longer matches an include is reported too, to be
# deleted (not failed: the fix may land on another branch first). Key: (file relative to the
# source dir, included path).
KNOWN_VIOLATIONS = set()  # (file, include) pairs being removed: reported, not failed

INCLUDE = re.compile(r'^\s*#\s*include\s*"([A-Za-z0-9_]+)/([^"]+)"')


def rule_broken(folder, target):
    """The rule an include from `folder` of a file in `target` breaks, or None."""
    if target == folder or target not in ALLOWED or target in ALLOWED[folder]:
        return None
    if target == "simulator":
        return "only cli/, tests/ and bench/ may include simulator/"
    if folder in MIDDLE and target in MIDDLE:
        return f"sideways: {folder}/ and {target}/ are siblings and never include one another"
    if folder == "simulator":
        return f"simulator/ may include only {', '.join(sorted(ALLOWED['simulator']))}"
    if ORDER.index(target) > ORDER.index(folder):
        return f"upwards: {folder}/ is below {target}/ and may not include it"
    return f"{folder}/ may not include {target}/ (allowed: {', '.join(sorted(ALLOWED[folder])) or 'nothing'})"


def check(source_dir, known=KNOWN_VIOLATIONS):
    """Returns (errors, notes, files_checked): lines to print."""
    errors, notes, seen, files = [], [], set(), 0
    for folder in ORDER:
        root = os.path.join(source_dir, folder)
        if not os.path.isdir(root):
            errors.append(f"{folder}/: missing; the layer table in {__file__} names it")
            continue
        for dirpath, dirnames, filenames in os.walk(root):
            dirnames.sort()
            for name in sorted(filenames):
                if not name.endswith((".h", ".cc")):
                    continue
                path = os.path.join(dirpath, name)
                rel = os.path.relpath(path, source_dir).replace(os.sep, "/")
                files += 1
                with open(path, encoding="utf-8", errors="replace") as f:
                    for number, line in enumerate(f, 1):
                        m = INCLUDE.match(line)
                        if not m:
                            continue
                        rule = rule_broken(folder, m.group(1))
                        if rule is None:
                            continue
                        included = f"{m.group(1)}/{m.group(2)}"
                        where = f'{rel}:{number}: #include "{included}": {rule}'
                        if (rel, included) in known:
                            seen.add((rel, included))
                            notes.append(f"{where} (known, to be removed; listed in KNOWN_VIOLATIONS)")
                        else:
                            errors.append(where)
    for rel, included in sorted(set(known) - seen):
        notes.append(f'{rel}: no longer includes "{included}": delete the entry from KNOWN_VIOLATIONS')
    return errors, notes, files


def self_test():
    """Builds small trees and checks that each broken rule is reported with its file:line."""
    cases = [
        ("acquisition/a.cc", "storage/run_store.h", "sideways"),
        ("nc_out/n.h", "compensation/spline.h", "sideways"),
        ("core/c.h", "acquisition/poller.h", "upwards"),
        ("report/r.cc", "job/measure_job.h", "upwards"),
        ("service/s.cc", "cli/main.h", "upwards"),
        ("job/j.cc", "simulator/gauge_simulator.h", "only cli/"),
        ("simulator/s.cc", "acquisition/poller.h", "simulator/ may include only"),
        ("report/r.h", "acquisition/poller.h", "may not include acquisition/"),
        ("plant/p.cc", "job/measure_job.h", "upwards"),
        ("plant/p.cc", "nc_out/table_writer.h", "may not include nc_out/"),
    ]
    failures = []

    def make_tree(root, extra):
        for folder in ORDER:
            os.makedirs(os.path.join(root, folder))
        # A tree that obeys every rule, with the edges allowed today.
        write(root, "cli/main.cc", ["simulator/gauge_simulator.h", "service/daemon.h", "core/result.h"])
        write(root, "job/measure_job.cc", ["report/run_json.h", "acquisition/poller.h", "nc_out/table_writer.h"])
        write(root, "simulator/virtual_grinder.cc", ["compensation/wheel_path.h", "nc_out/table_writer.h"])
        write(root, "storage/run_store.h", ["core/result.h", "storage/schema.h"])
        for rel, included in extra:
            write(root, rel, [included])

    def write(root, rel, includes):
        with open(os.path.join(root, rel), "a", encoding="utf-8") as f:
            f.write("// test file\n#include <vector>\n")
            for included in includes:
                f.write(f'#include "{included}"\n')

    with tempfile.TemporaryDirectory() as root:
        make_tree(root, [])
        errors, _, _ = check(root, known=set())
        if errors:
            failures.append(f"a tree that obeys the rules failed: {errors}")

    for rel, included, rule in cases:
        with tempfile.TemporaryDirectory() as root:
            make_tree(root, [(rel, included)])
            errors, _, _ = check(root, known=set())
            # write() puts the include on line 3 of a new file.
            expected = f'{rel}:3: #include "{included}": '
            if len(errors) != 1 or not errors[0].startswith(expected) or rule not in errors[0]:
                failures.append(f"{rel} including {included}: expected one error '{expected}...{rule}...', got {errors}")

    with tempfile.TemporaryDirectory() as root:
        make_tree(root, [("config/c.h", "service/http_api.h")])
        known = {("config/c.h", "service/http_api.h")}
        errors, notes, _ = check(root, known=known)
        if errors or len(notes) != 1:
            failures.append(f"a known violation should be a note, not an error: {errors} {notes}")
    with tempfile.TemporaryDirectory() as root:
        make_tree(root, [])
        errors, notes, _ = check(root, known={("config/c.h", "service/http_api.h")})
        if errors or len(notes) != 1 or "delete the entry from KNOWN_VIOLATIONS" not in notes[0]:
            failures.append(f"a stale known violation should be a note: {errors} {notes}")

    for failure in failures:
        print(f"self-test: {failure}")
    print(f"self-test: {len(cases) + 3 - len(failures)} of {len(cases) + 3} cases as expected")
    return 1 if failures else 0


def main(argv):
    if argv[1:] == ["--self-test"]:
        return self_test()
    if len(argv) > 2:
        print(__doc__, file=sys.stderr)
        return 2
    source_dir = argv[1] if len(argv) == 2 else os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..")
    errors, notes, files = check(source_dir)
    for note in notes:
        print(f"note: {note}")
    for error in errors:
        print(f"error: {error}")
    print(f"layering: {files} files checked, {len(errors)} errors, {len(notes)} notes")
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
