#!/usr/bin/python3
"""Compares two runs of RegistrationDecisions.DISABLED_AgainstTheTruth (tests/register/
test_decisions_against_truth.cpp) decision by decision: prints every decision whose status
changed (RIGHT / WRONG / REFUSED, or a refusal's reason), counts (before, after) statuses, and
sums the CPU of the pairs both runs registered.

    /usr/bin/python3 benchmarks/bench_register_decisions_compare.py before.log after.log
"""
import sys
from collections import Counter


def load(path):
    status, cpu = {}, {}
    with open(path) as f:
        for line in f:
            if not line.startswith("D "):
                continue
            key, value = line[2:].split(": ", 1)
            parts = value.split(" | ")
            status[key] = parts[0].strip()
            if len(parts) > 1:
                cpu[key] = float(parts[1].split()[1])
    return status, cpu


def main():
    if len(sys.argv) != 3:
        sys.exit("usage: bench_register_decisions_compare.py before.log after.log")
    (before, before_cpu), (after, after_cpu) = load(sys.argv[1]), load(sys.argv[2])
    common = [k for k in before if k in after]
    if not common:
        sys.exit(f"{sys.argv[1]} and {sys.argv[2]}: no decision in common")
    changes = Counter()
    for key in common:
        a, b = before[key].split()[0], after[key].split()[0]
        changes[(a, b)] += 1
        if a != b or (a == "REFUSED" and before[key] != after[key]):
            print(f"{key}\n   before: {before[key][:160]}\n   after:  {after[key][:160]}")
    for (a, b), n in sorted(changes.items()):
        print(f"{a} -> {b}: {n}")
    print(f"{len(common)} decisions in common")
    pairs = [k for k in before_cpu if k in after_cpu]
    if pairs:
        print("pair CPU sum: before %.2f s, after %.2f s over %d pairs" %
              (sum(before_cpu[k] for k in pairs), sum(after_cpu[k] for k in pairs), len(pairs)))


if __name__ == "__main__":
    main()
