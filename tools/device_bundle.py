"""Build what a bare GPU machine needs to run ``tools/device_check.sh``, into ``.devbundle/``.

The lent GPU machines have Python 3.12 with numpy, scipy and scikit-image but no VTK,
PyVista, USD, Dask or zarr, reach no package index, and take at most 64 MiB of files a
call. So: download the CPython 3.12 wheels here, unpack them, keep of VTK and USD only the
modules the device plan imports (``tools/device_modules.txt``, written by ``--record``,
which runs the plan's code paths small) and the libraries those link to, put a ``vtk``
module in place of VTK's own (which imports all 150 modules) that imports the one holding
each name asked for, and pack the lot as one xz tarball. Also fetches the GL loader
packages the device README asks for (``.gl/``). Usage: ``.venv/bin/python
tools/device_bundle.py [--record]`` (both folders are git-ignored).
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BUNDLE = ROOT / ".devbundle"
WHEELS = ["vtk==9.7.2", "pyvista==0.49.2", "pyvista-validation==0.2.2", "scooby==0.12.1",
          "pooch==1.9.0", "platformdirs", "usd-core==26.11", "trimesh", "dask==2026.8.0",
          "distributed==2026.8.0", "zarr==3.1.6", "numcodecs==0.16.6", "donfig==0.8.1.post1",
          "google-crc32c==1.9.0", "tblib==3.2.2", "zict==3.0.0", "locket==1.0.0",
          "partd==1.4.2", "tornado==6.6.1", "more-itertools"]
PLATFORMS = [f"manylinux_2_{n}_x86_64" for n in (17, 24, 27, 28, 31, 34)] + [
    "manylinux2014_x86_64", "manylinux1_x86_64"]
GL_DEBS = ["libvulkan1", "libegl1", "libglvnd0", "libopengl0", "libgl1", "libglx0", "libgles2"]
#: What ``--record`` runs (small sizes, EGL) to learn which modules the device plan imports.
RECORD = [
    ["bench", "device", "--plan", "quick", "--out", "{tmp}/quick"],
    ["bench", "tradeoff", "vtk", "direct", "cubemap", "pyvista", "--size", "160x120",
     "--frames", "3", "--workers", "2"],
    ["bench", "voxels", "--sizes", "100x100", "--large", "32", "--frames", "3", "--workers",
     "2"],
    ["bench", "surfaces", "--size", "100x100", "--grids", "16", "--steps", "50", "--frames",
     "3", "--workers", "2"],
    ["bench", "resolution", "--sizes", "160x120", "--crop", "32", "--frames", "3",
     "--workers", "2"],
    ["bench", "cluster", "--scenes", "smoke,direct,cubemap,voxels,surface", "--frames", "4",
     "--workers", "1", "--size", "80x60"],
    ["bench", "sortlast", "--shape", "24x16x12", "--frames", "2", "--partitions", "2",
     "--workers", "1", "--size", "80x60"],
    ["info", "--gl"],
]
MODULES = ROOT / "tools" / "device_modules.txt"
#: Files no code reads at run time (type stubs, a static library, sample data but the nut
#: the surfaces bench draws, a dashboard's pictures): what takes the bundle under 64 MiB.
UNUSED_FILES = ["**/*.pyi", "**/*.a", "pyvista/examples/*.vti", "pyvista/examples/*.jpg",
                "pyvista/examples/*.png", "distributed/http/static/images", "*.dist-info/sboms"]
#: Imported by every process: logs each module as it is imported (an audit hook sees
#: the imports VTK's own finder serves, which a finder of ours placed first would not).
RECORDER = '''import os, sys
def _record(event, args):
    if event == "import" and args[0].startswith(("vtkmodules.", "pxr.")):
        with open(os.path.join({folder!r}, f"log.{{os.getpid()}}"), "a") as log:
            log.write(args[0] + "\\n")
sys.addaudithook(_record)
'''
SHIM = '''"""VTK's names, each imported from its own extension module on first use.

VTK's own ``vtk`` module imports all of its 150 modules; this one, written by
tools/device_bundle.py, imports only the one that holds the name asked for.
"""
import importlib

import vtkmodules as _package

__path__ = _package.__path__
__version__ = _package.__version__
_INDEX = {index!r}


def __getattr__(name):
    module = _INDEX.get(name)
    if module is None:
        raise AttributeError(f"module 'vtk' has no attribute {{name!r}} in this bundle")
    value = getattr(importlib.import_module("vtkmodules." + module), name)
    globals()[name] = value
    return value
'''


def vtk_index() -> dict[str, str]:
    """Every public name of VTK and the extension module that defines it (first one wins)."""
    import importlib.util

    import vtkmodules
    text = Path(importlib.util.find_spec("vtkmodules.all").origin).read_text()
    index = {}
    for module in re.findall(r"from \.(vtk\w+) import \*", text):
        try:
            loaded = importlib.import_module("vtkmodules." + module)
        except ImportError:
            continue
        for name in dir(loaded):
            if not name.startswith("_"):
                index.setdefault(name, module)
    assert vtkmodules.__version__ == WHEELS[0].split("==")[1], "record with the bundled VTK"
    return index


def record() -> None:
    """Run the device plan's code paths small, with the shim, and list the modules imported."""
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        (folder / "vtk.py").write_text(SHIM.format(index=vtk_index()))
        (folder / "sitecustomize.py").write_text(RECORDER.format(folder=tmp))
        env = {**os.environ, "PYTHONPATH": tmp, "PV_CUBEMARCH_GL": "egl"}
        for command in RECORD:
            args = [a.replace("{tmp}", tmp) for a in command]
            subprocess.run([sys.executable, "-m", "pv_cubemarch.cli", *args], check=True,
                           env=env, cwd=ROOT, stdout=subprocess.DEVNULL)
        names = {line.strip() for log in folder.glob("log.*")
                 for line in log.read_text().splitlines()}
    top = sorted({".".join(n.split(".")[:2]) for n in names})
    MODULES.write_text("# written by tools/device_bundle.py --record\n" + "\n".join(top) + "\n")
    print(f"{MODULES}: {len(top)} modules")


def download(folder: Path) -> None:
    folder.mkdir(parents=True, exist_ok=True)
    platforms = [arg for p in PLATFORMS for arg in ("--platform", p)]
    for wheel in WHEELS:
        subprocess.run([sys.executable, "-m", "pip", "download", "-q", "--no-deps",
                        "--only-binary=:all:", "--python-version", "3.12", "--implementation",
                        "cp", *platforms, "-d", str(folder), wheel], check=True)


def recorded() -> tuple[list[str], list[str]]:
    """The vtkmodules and pxr packages ``--record`` saw imported, plus a few to be safe."""
    names = [line for line in MODULES.read_text().splitlines() if not line.startswith("#")]
    vtk = {n.split(".")[1] for n in names if n.startswith("vtkmodules.vtk")}
    vtk |= {"vtkRenderingOpenGL2", "vtkRenderingVolumeOpenGL2", "vtkRenderingUI",
            "vtkInteractionStyle", "vtkRenderingFreeType", "vtkIOXML", "vtkIOLegacy",
            "vtkIOImage", "vtkFiltersSources", "vtkFiltersGeneral", "vtkFiltersCore"}
    pxr = {n.split(".")[1] for n in names if n.startswith("pxr.")}
    return sorted(vtk), sorted(pxr)


def needed(library: Path) -> list[str]:
    out = subprocess.run(["readelf", "-d", str(library)], capture_output=True, text=True).stdout
    return re.findall(r"\(NEEDED\)\s+Shared library: \[(.+?)\]", out)


def trim_vtk(site: Path, modules: list[str]) -> None:
    """Keep the extension modules named and the libraries they link to; write the shim."""
    folder = site / "vtkmodules"
    keep = {p for m in modules for p in folder.glob(f"{m}.cpython-*.so")}
    stack = list(keep)
    while stack:
        for name in needed(stack.pop()):
            path = folder / name
            if path.exists() and path not in keep:
                keep.add(path)
                stack.append(path)
    for path in folder.glob("*.so*"):
        if path not in keep:
            path.unlink()
    for sub in ("qt", "tk", "wx", "gtk", "test", "web"):
        shutil.rmtree(folder / sub, ignore_errors=True)
    kept = {p.name.split(".")[0] for p in keep if ".cpython-" in p.name}
    index = {name: module for name, module in vtk_index().items() if module in kept}
    (site / "vtk.py").write_text(SHIM.format(index=index))


def trim_pxr(site: Path, packages: list[str]) -> None:
    """Drop the pxr packages nothing imported; ``pxr/pluginfo`` (the schemas) stays."""
    for folder in (site / "pxr").iterdir():
        if (folder / "__init__.py").exists() and folder.name not in packages:
            shutil.rmtree(folder)


def main() -> None:
    if "--record" in sys.argv[1:]:
        record()
        return
    wheels = BUNDLE / "whl"
    if len(list(wheels.glob("*.whl"))) < len(WHEELS):
        download(wheels)
    site = BUNDLE / "site"
    shutil.rmtree(site, ignore_errors=True)
    site.mkdir(parents=True)
    for wheel in sorted(wheels.glob("*.whl")):
        with zipfile.ZipFile(wheel) as archive:
            archive.extractall(site)
    vtk_modules, pxr_packages = recorded()
    trim_vtk(site, vtk_modules)
    trim_pxr(site, pxr_packages)
    for pattern in UNUSED_FILES:
        for path in site.glob(pattern):
            shutil.rmtree(path) if path.is_dir() else path.unlink()
    for cache in site.rglob("__pycache__"):
        shutil.rmtree(cache, ignore_errors=True)
    libraries = [str(p) for p in site.rglob("*.so*") if p.is_file()]
    for so in libraries:
        os.chmod(so, 0o755)
    # symbols only debuggers read: a third of VTK's and USD's size (tried: the same images)
    subprocess.run(["strip", "--strip-unneeded", *libraries], check=True)
    target = BUNDLE / "site.tar.xz"
    subprocess.run(["tar", "-C", str(site), "-cf", str(target), "-I", "xz -9 -T0", "."],
                   check=True)
    print(f"{target}: {target.stat().st_size / 2**20:.1f} MiB")
    gl = ROOT / ".gl"
    gl.mkdir(exist_ok=True)
    lists = Path("/tmp/amd64")
    (lists / "partial").mkdir(parents=True, exist_ok=True)
    apt = ["apt-get", "-oAPT::Architecture=amd64", "-oAPT::Architectures=amd64",
           f"-oDir::State::Lists={lists}"]
    subprocess.run([*apt, "-qq", "update"], check=True)
    subprocess.run([*apt, "-qq", "download", *GL_DEBS], check=True, cwd=gl)
    print(f"{gl}: {', '.join(sorted(p.name for p in gl.glob('*.deb')))}")


if __name__ == "__main__":
    main()
