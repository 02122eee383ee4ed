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
