"""Load FMU packages the way the FMU's bridge does and run their models: what the runtime must carry.

A standalone script (it imports nothing of the harness), run by :mod:`harness.build.runtime_bundle` in a
subprocess of the build interpreter started with ``-I -S`` (no site, no environment):

    python -I -S runtime_probe.py SPEC.json OUT.json PATH...

``sys.path`` becomes exactly the PATH arguments before anything is imported (so every module the
script and the models load comes from there, but those the interpreter loaded starting up).
SPEC: ``{"fmus": [{"package": ".../resources/spurdiff", "class": "Name",
"module": "_fmu_entry", "experiment": {"startTime", "stepSize"}, "steps": 20}]}``.

``spurdiff`` and ``pythonfmu`` cannot be imported by those names at all. Each FMU's package folder is
loaded as a top-level package under a private alias (``_spurdiff_fmu_<16 hex>``, as the bridge
does), its class instantiated with the bridge's arguments and run through the adapter's
``fmi2_*`` methods: setup, initialization, ``steps`` steps of the default step size with the
state got, serialized, deserialized and set back half-way, all Real values read, terminate. A
refused call raises with the model's reason and its log.

OUT: ``{"modules": {name: file, "frozen", "built-in" or null}, "libraries": [shared objects mapped],
"results": {class: [the Real values after the last step]}}``.
"""
import sys

if __name__ == "__main__":
    sys.path[:] = sys.argv[3:]     # before any import: the modules below come from there too

import hashlib  # noqa: E402
import importlib  # noqa: E402
import importlib.util  # noqa: E402
import json  # noqa: E402
import os  # noqa: E402

BLOCKED = ("spurdiff", "pythonfmu")


class _Guard:
    """Refuses the global names of the FMU's own packages (the FMU loads its own copy under a private
    name; what else the FMU's runtime does not carry is not on the module path at all)."""

    def find_spec(self, fullname, path=None, target=None):
        if fullname.partition(".")[0] in BLOCKED:
            raise ModuleNotFoundError(f"{fullname!r} imported by its global name: the FMU loads its own copy "
                                      "under a private name", name=fullname)
        return None


def load_package(folder):
    """The package ``folder`` loaded as a top-level package under its private alias, as the bridge
    does: from the archive ``<folder>.zip`` when there is one (an extracted FMU), else from the
    folder (a staged copy); returns the alias."""
    alias = "_spurdiff_fmu_" + hashlib.sha256(os.path.realpath(folder).encode()).hexdigest()[:16]
    if alias not in sys.modules:
        archive, code = folder + ".zip", None
        if os.path.isfile(archive):
            import zipimport
            inner = os.path.join(archive, os.path.basename(folder))
            top = zipimport.zipimporter(archive)
            code = top.get_code(os.path.basename(folder))
            spec = importlib.util.spec_from_loader(alias, top, origin=os.path.join(inner, "__init__.py"),
                                                   is_package=True)
            spec.submodule_search_locations = [inner]
            spec.has_location = True
        else:
            spec = importlib.util.spec_from_file_location(alias, os.path.join(folder, "__init__.py"),
                                                          submodule_search_locations=[folder])
        module = importlib.util.module_from_spec(spec)
        sys.modules[alias] = module
        if code is None:
            spec.loader.exec_module(module)
        else:
            exec(code, module.__dict__)
    return alias


def _check(slave, status, call):
    if status is not None and status > 1:
        log = "; ".join(str(getattr(m, "msg", m)) for m in getattr(slave, "log_queue", []))
        raise RuntimeError(f"{call} returned status {status}: {getattr(slave, 'failure', '')} (log: {log})")


def run(fmu):
    alias = load_package(fmu["package"])
    cls = getattr(importlib.import_module(f"{alias}.{fmu['module']}"), fmu["class"])
    resources = os.path.dirname(fmu["package"])
    slave = cls(instance_name="probe", resources=resources, visible=False, logging_on=False)
    experiment = fmu["experiment"]
    t, h = float(experiment.get("startTime", 0.0)), float(experiment["stepSize"])
    steps = int(fmu.get("steps", 20))
    _check(slave, slave.fmi2_setup_experiment(False, 0.0, t, False, 0.0), "fmi2SetupExperiment")
    _check(slave, slave.fmi2_enter_initialization_mode(), "fmi2EnterInitializationMode")
    _check(slave, slave.fmi2_exit_initialization_mode(), "fmi2ExitInitializationMode")
    reals = [vr for vr, v in slave.vars.items() if type(v).__name__ == "Real"]
    for k in range(steps):
        if k == steps // 2:
            state = slave.fmi2_get_state()
            again = slave.fmi2_deserialize_state(slave.fmi2_serialize_state(state))
            _check(slave, slave.fmi2_set_state(again), "fmi2SetFMUstate")
        _check(slave, slave.fmi2_do_step(t, h), "fmi2DoStep")
        t += h
    values = [float(x) for x in slave.fmi2_get_real(reals)]
    _check(slave, slave.fmi2_terminate(), "fmi2Terminate")
    return values


def _origin(module):
    """The module's file, or "frozen"/"built-in" for one held in the interpreter itself."""
    spec = getattr(module, "__spec__", None)
    if spec is not None and spec.origin in ("frozen", "built-in"):
        return spec.origin
    return getattr(module, "__file__", None)


def mapped_libraries():
    found = set()
    try:
        with open("/proc/self/maps") as f:
            for line in f:
                parts = line.split(None, 5)
                if len(parts) == 6 and ".so" in parts[5]:
                    found.add(parts[5].strip())
    except OSError:
        pass
    return sorted(found)


def main(spec_file, out_file):
    with open(spec_file) as f:
        spec = json.load(f)
    sys.dont_write_bytecode = True
    sys.meta_path.insert(0, _Guard())
    results = {fmu["class"]: run(fmu) for fmu in spec["fmus"]}
    modules = {name: _origin(m) for name, m in sorted(sys.modules.items()) if m is not None and name != "__main__"}
    with open(out_file, "w") as f:
        json.dump({"modules": modules, "libraries": mapped_libraries(), "results": results}, f)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2]))
