"""How deeply a text's brackets and braces nest, before a recursive parser reads it: Python's
json and tomllib recurse once a level, and where they give up depends on the Python (3,000
levels of a state's meta were a RecursionError on 3.11 and a list on 3.12.3), so the limit is
ours, the same everywhere."""

MAX_DEPTH = 32  # brackets and braces open at once: a run file, a key file or a state's meta


def check_nesting(text, what):
    """ValueError naming ``what`` where ``text`` opens more than MAX_DEPTH brackets and braces
    at once (strings included: an upper bound of the nesting)."""
    depth = deepest = 0
    for char in text:
        if char in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif char in "]}":
            depth = max(0, depth - 1)
    if deepest > MAX_DEPTH:
        raise ValueError(f"nested {deepest} levels deep; {what} needs at most {MAX_DEPTH}")
