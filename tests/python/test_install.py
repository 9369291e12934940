"""ctest python_install: the binding installs the way README.md says, offline.

Copies examples/python into WORK (so that pip's build/ and *.egg-info land in
the build tree, not the checkout), creates a fresh virtual environment
WORK/venv and installs the package into it with README's offline command

    python3 -m venv --system-site-packages WORK/venv
    WORK/venv/bin/pip install --no-build-isolation WORK/src

(with PIP_NO_INDEX=1, so nothing is fetched), then runs installed_check.py
with the environment's python, outside the checkout, with AACBVH_LIBRARY
pointing at the built library: it imports the installed module, builds a BVH
and checks its hits.

Reports "python_install SKIPPED: ..." (ctest shows the test as skipped) where
the interpreter cannot make such an environment offline: no ensurepip
(Debian's python3-venv), or no setuptools >= 61 and wheel for the build
(python3-setuptools, python3-wheel). Any other failure fails the test.

    python3 tests/python/test_install.py --source examples/python \\
        --work /tmp/aacbvh-install --library build/capi/libaacbvh.so.1
"""
import argparse
import importlib.util
import os
import shutil
import subprocess
import sys

HERE = os.path.dirname(os.path.abspath(__file__))


def skip(why):
    print("python_install SKIPPED: %s" % why)
    sys.exit(0)


def has_module(name):
    try:
        return importlib.util.find_spec(name) is not None
    except (ImportError, ValueError):
        return False


def run(command, env, cwd):
    print("+ " + " ".join(command), flush=True)
    done = subprocess.run(command, env=env, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          universal_newlines=True, timeout=240)
    print(done.stdout, flush=True)
    return done


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--source", required=True, help="examples/python of the checkout")
    parser.add_argument("--work", required=True, help="a folder in the build tree (emptied first)")
    parser.add_argument("--library", required=True, help="the built libaacbvh.so.1")
    args = parser.parse_args()

    python = sys.executable
    if not has_module("venv") or not has_module("ensurepip"):
        skip("%s has no venv/ensurepip (on Debian: apt-get install python3-venv)" % python)
    # What the offline build needs from the system (the environment sees it
    # through --system-site-packages).
    try:
        import setuptools
        import wheel  # noqa: F401  (setuptools < 70.1 builds wheels with it)
    except ImportError as e:
        skip("%s lacks %s for an offline build (on Debian: apt-get install python3-setuptools python3-wheel; "
             "or configure with -DPython3_EXECUTABLE=/usr/bin/python3)" % (python, e.name))
    if int(setuptools.__version__.split(".")[0]) < 61:
        skip("setuptools %s of %s is older than 61, which reads pyproject.toml's [project]"
             % (setuptools.__version__, python))

    work = os.path.abspath(args.work)
    shutil.rmtree(work, ignore_errors=True)
    os.makedirs(work)
    src, venv = os.path.join(work, "src"), os.path.join(work, "venv")
    shutil.copytree(args.source, src, ignore=shutil.ignore_patterns("__pycache__", "build", "*.egg-info"))

    env = dict(os.environ)
    for name in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV", "AACBVH_LIBRARY"):
        env.pop(name, None)
    env.update(PIP_NO_INDEX="1", PIP_DISABLE_PIP_VERSION_CHECK="1", PIP_NO_CACHE_DIR="1")

    done = run([python, "-m", "venv", "--system-site-packages", venv], env, work)
    if done.returncode != 0:
        if "ensurepip" in done.stdout:
            skip("%s cannot make a virtual environment with pip (on Debian: apt-get install python3-venv)" % python)
        sys.exit("python_install FAILED: python3 -m venv exited with %d" % done.returncode)
    pip, venv_python = os.path.join(venv, "bin", "pip"), os.path.join(venv, "bin", "python")
    done = run([pip, "install", "--no-build-isolation", src], env, work)
    if done.returncode != 0:
        sys.exit("python_install FAILED: pip install exited with %d" % done.returncode)

    env["AACBVH_LIBRARY"] = os.path.abspath(args.library)
    done = run([venv_python, os.path.join(HERE, "installed_check.py"), venv], env, work)
    if done.returncode != 0:
        sys.exit("python_install FAILED: the installed package's check exited with %d" % done.returncode)
    print("python_install PASSED")


if __name__ == "__main__":
    main()
