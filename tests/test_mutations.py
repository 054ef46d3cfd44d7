"""The shader mutation suite (tests/mutations.py) in the test command: every mutation still applies
to the code as it is, and a subset, one or two per area, is caught by the tests named for it.
The full table: python -m tests.mutations (docs/mutations.md)."""

import pytest

from mutations import CI_SUBSET, MUTATIONS, ROOT, run_all


def test_every_mutation_applies_to_the_code_as_it_is():
    """A mutation whose text moved would stop the suite; this says so in the fast tier."""
    for mutation in MUTATIONS:
        texts = {}
        for path, old, new in mutation.edits:
            text = texts.get(path) or (ROOT / path).read_text()
            assert text.count(old) == 1, f"{mutation.name}: {old!r} is not once in {path}"
            texts[path] = text.replace(old, new)
        for test in mutation.tests:
            assert (ROOT / test.split("::")[0]).is_file(), f"{mutation.name}: no {test}"
    names = [m.name for m in MUTATIONS]
    assert len(set(names)) == len(names) >= 20
    assert set(CI_SUBSET) <= set(names)


@pytest.mark.gl
@pytest.mark.slow
def test_a_subset_of_the_mutations_is_caught():
    chosen = [m for m in MUTATIONS if m.name in CI_SUBSET]
    rows = run_all(chosen, echo=print)
    survivors = [f"{m.name} ({verdict})" for m, verdict, _, _ in rows if verdict != "caught"]
    assert not survivors, f"mutations not caught: {', '.join(survivors)}"
