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
