"""What memory the machine lets this process take: :func:`available`, the least of Linux's
MemAvailable, each enclosing cgroup's limit less its usage (v1 and v2) and the address-space
limit (``ulimit -v``) less the process's virtual size. Every run's estimate
(``frame/memory.py``) and the voxeliser's (``fields/field3d.py``) are checked against it."""

import os
import re
from dataclasses import dataclass, field

UNLIMITED = 2 ** 60  # a cgroup's "no limit" (v1 writes 2^63 rounded down to a page)


@dataclass(frozen=True)
class Room:
    """``bytes`` this process may still take, and which limit says so (``source``); ``bytes``
    None where no limit could be read."""

    bytes: int = None
    source: str = ""
    limits: dict = field(default_factory=dict)


def meminfo_room(text):
    """MemAvailable of /proc/meminfo's ``text``, in bytes (None where it has none)."""
    found = re.search(r"^MemAvailable:\s+(\d+)\s*kB", text or "", re.MULTILINE)
    return int(found.group(1)) * 1024 if found else None


def cgroup_room(files):
    """What one cgroup still allows, from its memory files' contents (``files``: file name ->
    text): v2's memory.max less memory.current, or v1's memory.limit_in_bytes less
    memory.usage_in_bytes, less in each case the inactive file cache of memory.stat (the kernel
    takes it back before it refuses). None where it sets no limit."""
    for limit_name, usage_name, inactive in (("memory.max", "memory.current", "inactive_file"),
                                             ("memory.limit_in_bytes", "memory.usage_in_bytes",
                                              "total_inactive_file")):
        limit, usage = files.get(limit_name), files.get(usage_name)
        if limit is None or usage is None:
            continue
        limit = limit.strip()
        if limit == "max" or not limit.isdigit() or int(limit) >= UNLIMITED:
            return None
        found = re.search(rf"^{inactive}\s+(\d+)", files.get("memory.stat", ""), re.MULTILINE)
        reclaimable = int(found.group(1)) if found else 0
        return max(int(limit) - max(int(usage.strip()) - reclaimable, 0), 0)
    return None


def address_space_room(limit, status):
    """RLIMIT_AS's soft ``limit`` less the process's virtual size (VmSize of /proc/self/status's
    ``status``), in bytes; None where there is no limit (RLIM_INFINITY) or no VmSize. (A run's
    virtual size grew by at most ~100 MiB more than its resident size, measured: within the
    estimate's margin.)"""
    if limit is None or limit < 0 or limit >= UNLIMITED:
        return None
    found = re.search(r"^VmSize:\s+(\d+)\s*kB", status or "", re.MULTILINE)
    if not found:
        return None
    return max(limit - int(found.group(1)) * 1024, 0)


def available(meminfo=None, cgroups=None, address_space=None, status=None):
    """The :class:`Room` this process has: the least of the machine's MemAvailable, each
    enclosing cgroup's limit less its usage, and the address-space limit (``ulimit -v``,
    RLIMIT_AS) less the process's virtual size, of those that apply.

    Each input is read from the system where None: ``meminfo``, the text of /proc/meminfo;
    ``cgroups``, the memory files of this process's cgroup and its ancestors, a list of
    {file name: text}; ``address_space``, RLIMIT_AS's soft limit in bytes (negative, as
    RLIM_INFINITY reads: none); ``status``, the text of /proc/self/status."""
    if meminfo is None:
        meminfo = _read("/proc/meminfo")
    if cgroups is None:
        cgroups = cgroup_files()
    if address_space is None:
        try:
            import resource

            address_space = resource.getrlimit(resource.RLIMIT_AS)[0]
        except (ImportError, AttributeError, OSError):
            address_space = None
    if status is None and address_space is not None:
        status = _read("/proc/self/status")
    limits = {"MemAvailable": meminfo_room(meminfo),
              "address-space limit, ulimit -v": address_space_room(address_space, status)}
    rooms = [room for room in map(cgroup_room, cgroups) if room is not None]
    limits["cgroup memory limit"] = min(rooms) if rooms else None
    known = {source: n for source, n in limits.items() if n is not None}
    if not known:
        return Room(None, "no limit could be read", limits)
    source = min(known, key=known.get)
    return Room(known[source], source, limits)


def cgroup_files(proc_cgroup=None, mountinfo=None):
    """The memory files of this process's cgroup and of each ancestor up to its mount, as
    [{file name: text}], for v2 (the unified hierarchy) and v1 (the memory controller)."""
    proc_cgroup = _read("/proc/self/cgroup") if proc_cgroup is None else proc_cgroup
    mountinfo = _read("/proc/self/mountinfo") if mountinfo is None else mountinfo
    out = []
    for line in (proc_cgroup or "").splitlines():
        parts = line.split(":", 2)
        if len(parts) != 3:
            continue
        _, controllers, path = parts
        if controllers == "":
            names, version = ("memory.max", "memory.current", "memory.stat"), 2
        elif "memory" in controllers.split(","):
            names, version = ("memory.limit_in_bytes", "memory.usage_in_bytes",
                              "memory.stat"), 1
        else:
            continue
        for mount_point, root in _cgroup_mounts(mountinfo, version):
            if not path.startswith(root):
                continue
            top = os.path.normpath(mount_point)
            folder = os.path.normpath(os.path.join(top, path[len(root):].lstrip("/")))
            while folder == top or folder.startswith(top + os.sep):
                files = {n: _read(os.path.join(folder, n)) for n in names}
                files = {n: t for n, t in files.items() if t is not None}
                if files:
                    out.append(files)
                if folder == top:
                    break
                folder = os.path.dirname(folder)
    return out


def _cgroup_mounts(mountinfo, version):
    """(mount point, root within the hierarchy) of each cgroup mount of ``version``."""
    for line in (mountinfo or "").splitlines():
        fields = line.split()
        if "-" not in fields:
            continue
        dash = fields.index("-")
        fs_type, options = fields[dash + 1], fields[-1].split(",")
        if (version == 2 and fs_type == "cgroup2") or (version == 1 and fs_type == "cgroup"
                                                        and "memory" in options):
            yield fields[4], fields[3]


def _read(path):
    try:
        with open(path, encoding="ascii", errors="replace") as f:
            return f.read()
    except OSError:
        return None
