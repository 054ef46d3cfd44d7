"""A tiny binary dilation for the image tests (no scipy dependency)."""



def dilate(mask, radius):
    """Pixels within ``radius`` (Chebyshev) of a True pixel."""
    out = mask.copy()
    for _ in range(radius):
        grown = out.copy()
        grown[1:] |= out[:-1]
        grown[:-1] |= out[1:]
        grown[:, 1:] |= out[:, :-1]
        grown[:, :-1] |= out[:, 1:]
        out = grown
    return out
