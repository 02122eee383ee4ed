import json
import subprocess
import sys


def run_ogacq(*args: str, timeout: float = 120, check_json: bool = False):
    proc = subprocess.run([sys.executable, "-m", "ogacq", *map(str, args)],
                          capture_output=True, text=True, timeout=timeout)
    if check_json:
        assert proc.returncode == 0, proc.stderr
        return json.loads(proc.stdout)
    return proc


# The disk "fills up" at ``limit`` bytes per file without root: RLIMIT_FSIZE with SIGXFSZ
# ignored makes every write past it fail with EFBIG in the kernel, as a write on a full
# disk fails with ENOSPC. The code under test runs for real, in its own process.
UNDER_FILE_SIZE_LIMIT = """
import resource, signal, sys
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
resource.setrlimit(resource.RLIMIT_FSIZE, (int(sys.argv[1]), resource.RLIM_INFINITY))
{body}
"""

OGACQ_MAIN = "from ogacq.cli.app import main\nsys.exit(main(sys.argv[2:]))\n"


def with_file_size_limit(limit: int, *args: object, body: str = OGACQ_MAIN,
                         timeout: float = 120) -> subprocess.CompletedProcess:
    """``body`` (default: ``ogacq ARGS``) in a process whose files cannot grow past
    ``limit`` bytes; ``sys.argv[2:]`` are ``args``."""
    return subprocess.run([sys.executable, "-c", UNDER_FILE_SIZE_LIMIT.format(body=body),
                           str(limit), *map(str, args)], capture_output=True, text=True,
                          timeout=timeout)


# A folder made read-only for one command. As root (whom permissions do not stop) or
# as a user allowed an unprivileged user namespace: a read-only bind mount of the
# folder over itself in a mount namespace of the command's own (util-linux unshare(1);
# mount(8) "remount,bind,ro"), so writes fail with EROFS as on a read-only file system
# and nothing outside the command sees it. Otherwise, as a user: the folder's and its
# files' write permission taken away for the command (EACCES). None when neither works
# (root in a container without CAP_SYS_ADMIN): the caller skips.
IN_READ_ONLY_MOUNT = """
import subprocess, sys
folder = sys.argv[1]
for args in (["mount", "--bind", folder, folder], ["mount", "-o", "remount,bind,ro", folder]):
    if subprocess.run(args, capture_output=True).returncode:
        sys.exit(97)
from ogacq.cli.app import main
sys.exit(main(sys.argv[2:]))
"""


def _unshare_prefix() -> list[str] | None:
    import os
    import shutil

    if shutil.which("unshare") is None or shutil.which("mount") is None:
        return None
    prefix = ["unshare", "--mount"] if os.geteuid() == 0 else \
        ["unshare", "--user", "--map-root-user", "--mount"]
    probe = subprocess.run([*prefix, "true"], capture_output=True)
    return prefix if probe.returncode == 0 else None


def on_read_only(folder, *args: object, timeout: float = 120,
                 ) -> subprocess.CompletedProcess | None:
    """``ogacq ARGS`` with ``folder`` (and all in it) read-only, as above; None when this
    machine cannot make it so."""
    import os
    from pathlib import Path

    prefix = _unshare_prefix()
    if prefix is not None:
        ran = subprocess.run([*prefix, sys.executable, "-c", IN_READ_ONLY_MOUNT, str(folder),
                              *map(str, args)], capture_output=True, text=True, timeout=timeout)
        if ran.returncode != 97:
            return ran
    if os.geteuid() == 0:
        return None
    paths = [Path(folder), *Path(folder).rglob("*")]
    modes = {p: p.stat().st_mode for p in paths}
    try:
        for p in paths:
            p.chmod(modes[p] & ~0o222)
        return run_ogacq(*args, timeout=timeout)
    finally:
        for p in reversed(paths):
            p.chmod(modes[p])
