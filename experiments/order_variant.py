"""`graspjax` with another chunk order for the devices, to measure what the order costs at the
end of a multi-GPU run (issue 53): among groups of equal device work per world (`Group.work`),
the later group in plan order first. For Tables 1+2 that plays g-l's Setup 1 chunks (3.3-4.5 s
each on an H200) before a-f's (2.2-2.7 s), so that the last chunks are the short ones. A
world's rows do not depend on the order.

    python3 experiments/order_variant.py run --table 1,2 --trials 4000 --seed 0 --out ...

The arguments are `graspjax`'s. Results: results/benchmarks/ (stop 64).
"""
from graspjax import cli
from graspjax.batch import program


def later_group_first_among_equals(todo, groups):
    """`program.heaviest_first`, ties in reverse plan order (plan order within a group)."""
    return sorted(todo, key=lambda c: (-groups[c.group].work / len(groups[c.group].worlds),
                                       -c.group))


if __name__ == "__main__":
    program.heaviest_first = later_group_first_among_equals
    cli.entry()
