"""Charts of the report, with matplotlib (the optional ``report`` extra). Each function writes one
PNG and returns its path; :func:`available` says whether matplotlib is installed."""


def available():
    try:
        import matplotlib  # noqa: F401
    except ImportError:
        return False
    return True


def _figure():
    import matplotlib

    matplotlib.use("Agg")  # headless
    import matplotlib.pyplot as plt

    return plt


def _finish(fig, ax, path, **labels):
    ax.set(**labels)
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    _save(fig, path)
    _figure().close(fig)
    return path


def _save(fig, path):
    """savefig through a random temporary name renamed onto ``path`` (a link there is
    replaced, not written through)."""
    from ..io.output import write_atomic

    write_atomic(path, lambda tmp: fig.savefig(tmp, format="png"))


LOG_FLOOR = 1e-12  # the bottom of the stiff chart's log axis: an exact 0 is drawn there


def work_precision(rows, time_key, error_key, path, title, xlabel, ylabel, floor_key=None):
    """Error (log) against run time (log), one series per format, one point per configuration;
    with ``floor_key``, the noise floor of each size as a grey dashed line (below it a
    difference means nothing)."""
    plt = _figure()
    fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=110)
    if floor_key is not None:
        first = sorted({r["series"] for r in rows})[0]
        series = sorted((r for r in rows if r["series"] == first), key=lambda r: r[time_key])
        ax.loglog([r[time_key] for r in series], [r[floor_key] for r in series], "--",
                  color="grey", label="noise floor (float64 vs float64)")
    for label in sorted({r["series"] for r in rows}):
        series = sorted((r for r in rows if r["series"] == label), key=lambda r: r[time_key])
        xs = [r[time_key] for r in series]
        ys = [max(r[error_key], 1e-12) for r in series]
        ax.loglog(xs, ys, "o-", label=label)
        for r in series:
            ax.annotate(f"2^{r['N'].bit_length() - 1}", (r[time_key], max(r[error_key], 1e-12)),
                        fontsize=7, xytext=(3, 3), textcoords="offset points")
    return _finish(fig, ax, path, xlabel=xlabel, ylabel=ylabel, title=title)


def error_against_dt(rows, path, fitted):
    plt = _figure()
    fig, ax = plt.subplots(figsize=(6.4, 4.4), dpi=110)
    for label in sorted({r["series"] for r in rows}):
        series = sorted((r for r in rows if r["series"] == label), key=lambda r: r["dt"])
        ax.loglog([r["dt"] for r in series], [max(r["error"], 1e-12) for r in series], "o-",
                  label=label)
    return _finish(fig, ax, path, xlabel="time step dt (s)",
                   ylabel="max position error at the horizon",
                   title=f"Collision integrator, smooth case: error against dt "
                         f"(fitted order {fitted:.2f})")


def stiff(curves, path):
    """Side by side: default integration and explicit Euler on the stiff cases."""
    plt = _figure()
    fig, axes = plt.subplots(1, len(curves), figsize=(4.2 * len(curves), 3.8), dpi=110)
    for ax, (title, steps, default, euler, exact, floor, ylabel) in zip(axes, curves):
        ax.semilogy(steps, exact, "k-", lw=1, label="exact")
        ax.semilogy(steps, default, "o-", label="default (as run on the GPU)")
        ax.semilogy(steps, euler, "s--", label="explicit Euler (numpy)")
        if floor is not None:
            ax.axhline(floor, color="grey", ls=":", label="half a code (16-bit state)")
            ax.set_ylim(bottom=LOG_FLOOR / 2)
            ax.annotate("0 is drawn at 1e-12", (steps[-1], LOG_FLOOR), fontsize=7,
                        ha="right", va="bottom")
        ax.set(title=title, xlabel="step", ylabel=ylabel)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=7)
    fig.tight_layout()
    _save(fig, path)
    plt.close(fig)
    return path
