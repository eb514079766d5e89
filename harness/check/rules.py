"""The rules of the compliance kit, as data: id, FMI 2.0 section, severity, calls, what is checked.

Severity comes from the standard's own words (FMI 2.0.x, "Functional Mock-up Interface for Model
Exchange and Co-Simulation"):

``error``
    the standard says *shall* / *must* / *has to*, or the call sequence is one the standard
    requires to work (its state machines, sections 3.2.3 and 4.2.4, list the call as allowed);
``warning``
    the standard says *should*, or the behaviour is left undefined (a call outside the allowed
    states, a step size the master must not use) and a robust FMU still handles it by refusing;
``info``
    good practice, and the conventions of a profile (``--profile``): the standard does not ask
    for them. A rule with a ``profile`` runs only when that profile is selected, and then its
    failures count as errors (the profile makes them requirements).

Exit code: 1 when any rule of severity error failed (``--strict``: or a warning), else 0.
The kinds: ``static`` (modelDescription.xml and archive, no binary loaded), ``cs`` (the
co-simulation call sequence, each rule in a fresh process), ``me`` (model exchange, likewise).
"""
from __future__ import annotations

from dataclasses import dataclass

ERROR, WARNING, INFO = "error", "warning", "info"
SEVERITIES = (ERROR, WARNING, INFO)

PROFILES = ("spurdiff",)


@dataclass(frozen=True)
class Rule:
    id: str
    section: str       # FMI 2.0 section, e.g. "2.1.5"
    severity: str      # error / warning / info (see the module docstring)
    calls: str         # the FMI calls (or the XML parts) the rule exercises
    summary: str       # what passes, in one sentence
    profile: str | None = None  # only with --profile NAME

    @property
    def kind(self) -> str:
        return self.id.split(".", 1)[0]

    def effective_severity(self, profiles: tuple[str, ...] = ()) -> str:
        return ERROR if self.profile is not None and self.profile in profiles else self.severity


R = Rule
RULES: tuple[Rule, ...] = (
    # ------------------------------------------------------------------ static (no binary)
    R("static.archive", "2.3", ERROR, "zip archive",
      "a readable zip within the kit's limits (members, unpacked size, modelDescription.xml size) whose "
      "member names are relative, '/'-separated, without '..', ':' or '\\', with modelDescription.xml at its root"),
    R("static.fmi2", "2.2.1", ERROR, "fmiModelDescription",
      'fmiVersion="2.0" and a CoSimulation or ModelExchange element with a modelIdentifier'),
    R("static.fmpy-validate", "2.2", ERROR, "modelDescription.xml",
      "fmpy.validation.validate_fmu: XML schema, unique names, ModelStructure, start values, "
      "causality/variability/initial combinations, units against UnitDefinitions"),
    R("static.binary", "2.3", ERROR, "binaries/<platform>/",
      "binaries/<platform>/<modelIdentifier><ext> exists for the platform the kit runs on (else nothing can run here)"),
    R("static.names", "2.2.9", ERROR, "ScalarVariable/@name",
      'names legal for variableNamingConvention ("structured": the grammar of 2.2.9; "flat": no CR, LF, tab)'),
    R("static.model-exchange", "3.3, 2.2.8", ERROR, "ModelExchange, ModelStructure/Derivatives",
      "each ModelStructure/Derivatives entry names a continuous Real derivative of a continuous Real state; "
      "numberOfEventIndicators is a non-negative integer"),
    R("static.output-dependencies", "2.2.8", INFO, "ModelStructure/Outputs/@dependencies",
      "outputs of an FMU with inputs declare their dependencies (without, an importer must assume direct "
      "feedthrough from every input)"),
    R("static.units", "2.2.7", INFO, "Real/@unit",
      'every Real has a unit or a declaredType with one (unit="1" for dimensionless)', profile="spurdiff"),
    R("static.descriptions", "2.2.7", INFO, "ScalarVariable/@description",
      "every variable has a description", profile="spurdiff"),
    R("static.all-output-dependencies", "2.2.8", INFO, "ModelStructure/Outputs/@dependencies",
      "every output declares its dependencies, also without inputs", profile="spurdiff"),
    # ------------------------------------------------------------------ co-simulation
    R("cs.version", "2.1.4", ERROR, "fmi2GetVersion, fmi2GetTypesPlatform",
      'fmi2GetVersion returns "2.0" and fmi2GetTypesPlatform "default" (the standard header\'s types)'),
    R("cs.basic", "4.2.4", ERROR,
      "fmi2Instantiate, fmi2SetupExperiment, fmi2Enter/ExitInitializationMode, fmi2DoStep, fmi2Get*, fmi2Terminate, fmi2FreeInstance",
      "the basic call sequence (--steps doSteps of the DefaultExperiment step) is accepted"),
    R("cs.guid", "2.1.5", ERROR, "fmi2Instantiate",
      "fmi2Instantiate with a GUID other than the modelDescription's returns NULL"),
    R("cs.logger", "2.1.5", ERROR, "fmi2CallbackLogger",
      "every message reaches the logger with the componentEnvironment given to fmi2Instantiate and the "
      "instance's name"),
    R("cs.debug-logging", "2.1.5", ERROR, "fmi2SetDebugLogging",
      "fmi2SetDebugLogging with the declared LogCategories, with none (all) and off is accepted"),
    R("cs.initial-unknowns", "2.1.7, 2.2.8", ERROR, "fmi2Get* in initialization mode",
      "in initialization mode the InitialUnknowns, outputs with initial exact/approx and calculated parameters "
      "can be read"),
    R("cs.default-experiment", "2.2.5, 4.2.2", ERROR, "fmi2SetupExperiment(stopTimeDefined), fmi2DoStep",
      "a run from the DefaultExperiment start to its stop time at its step size, with the stop time "
      "defined, is accepted and its Real outputs stay finite"),
    R("cs.stop-time", "2.1.6", ERROR, "fmi2SetupExperiment(stopTimeDefined), fmi2DoStep",
      "with the stop time defined, a doStep past it is refused with fmi2Error (refusing with fmi2Discard: warning)"),
    R("cs.status-after-discard", "4.2.3", ERROR,
      "fmi2GetStatus, fmi2GetRealStatus(fmi2LastSuccessfulTime), fmi2GetBooleanStatus(fmi2Terminated)",
      "after a discarded doStep (past the stop time, in the default experiment, or with NaN inputs) the status "
      "calls answer (fmi2Discard for a status the slave cannot give, never fmi2Error/Fatal) and "
      "fmi2LastSuccessfulTime lies within the refused step"),
    R("cs.get-after-terminate", "4.2.4", ERROR, "fmi2Terminate, fmi2Get*",
      "after fmi2Terminate the outputs can still be read (state terminated allows fmi2Get*)"),
    R("cs.reset", "2.1.6", ERROR, "fmi2Reset",
      "after fmi2Reset the same run gives the same outputs"),
    R("cs.two-instances", "2.1.5", ERROR, "fmi2Instantiate x 2",
      "two instances at once each give the outputs they give alone (unless canBeInstantiatedOnlyOncePerProcess)"),
    R("cs.get-set-state", "2.1.8", ERROR, "fmi2GetFMUstate, fmi2SetFMUstate",
      "(canGetAndSetFMUstate) setting a saved state repeats the continuation"),
    R("cs.free-state", "2.1.8", ERROR, "fmi2GetFMUstate, fmi2SetFMUstate, fmi2FreeFMUstate",
      "(canGetAndSetFMUstate) a state set twice repeats the continuation twice, fmi2GetFMUstate overwrites "
      "a given state, fmi2FreeFMUstate succeeds and sets the pointer to NULL, freeing NULL is ignored"),
    R("cs.serialize-state", "2.1.8", ERROR, "fmi2SerializeFMUstate, fmi2DeSerializeFMUstate",
      "(canSerializeFMUstate) a serialized state restored into a fresh instance continues the same"),
    R("cs.variable-step", "4.3.1", ERROR, "fmi2DoStep",
      "(canHandleVariableCommunicationStepSize) varying step sizes are accepted, outputs stay finite"),
    R("cs.interpolate-inputs", "4.2.1, 4.3.1", ERROR, "fmi2SetRealInputDerivatives",
      "(canInterpolateInputs) first derivatives of the Real inputs are accepted"),
    R("cs.output-derivatives", "4.2.1, 4.3.1", ERROR, "fmi2GetRealOutputDerivatives",
      "(maxOutputDerivativeOrder >= 1) first derivatives of the Real outputs are given, finite"),
    R("cs.directional-derivative", "2.1.9", ERROR, "fmi2GetDirectionalDerivative",
      "(providesDirectionalDerivative) derivatives of the outputs with respect to the Real inputs after a "
      "step (without inputs: of the InitialUnknowns with respect to their dependencies, in initialization "
      "mode) are given, finite"),
    R("cs.step-before-init", "4.2.4", WARNING, "fmi2DoStep",
      "a doStep before initialization (not allowed in state instantiated) is refused"),
    R("cs.zero-step-size", "4.2.2", WARNING, "fmi2DoStep",
      "a doStep with communicationStepSize = 0 (it must be > 0) is refused"),
    R("cs.negative-step-size", "4.2.2", WARNING, "fmi2DoStep",
      "a doStep with a negative communicationStepSize (it must be > 0) is refused"),
    R("cs.nan-inputs", "2.1.7", WARNING, "fmi2SetReal, fmi2DoStep",
      "NaN on the Real inputs is refused or shows in the outputs, not silently ignored"),
    R("cs.parameter-after-init", "2.1.7, 4.2.4", INFO, "fmi2SetReal/Integer/Boolean after initialization",
      "a fixed parameter set after initialization (not allowed then; behaviour undefined) is refused",
      profile="spurdiff"),
    # ------------------------------------------------------------------ model exchange
    R("me.basic", "3.2.3", ERROR,
      "fmi2Instantiate(fmi2ModelExchange), fmi2SetupExperiment, fmi2Enter/ExitInitializationMode, "
      "fmi2NewDiscreteStates, fmi2EnterContinuousTimeMode, fmi2SetTime, fmi2Get/SetContinuousStates, "
      "fmi2GetDerivatives, fmi2GetEventIndicators, fmi2CompletedIntegratorStep, fmi2EnterEventMode, "
      "fmi2Terminate, fmi2FreeInstance",
      "the model-exchange call sequence, driven by explicit Euler at the DefaultExperiment step to its stop "
      "time with event iteration at state, time and step events, is accepted; states and derivatives finite"),
    R("me.directional-derivative", "2.1.9, 3.2.2", ERROR, "fmi2GetDirectionalDerivative, fmi2GetDerivatives",
      "(providesDirectionalDerivative) in continuous-time mode the state Jacobian (derivatives with respect to "
      "the states) is given and matches central differences of fmi2GetDerivatives within 1e-4 (relative)"),
    R("me.guid", "2.1.5", ERROR, "fmi2Instantiate(fmi2ModelExchange)",
      "fmi2Instantiate with a GUID other than the modelDescription's returns NULL"),
)

BY_ID: dict[str, Rule] = {r.id: r for r in RULES}


def rules(kind: str | None = None, profiles: tuple[str, ...] = ()) -> tuple[Rule, ...]:
    """The rules that run: of ``kind`` (static / cs / me; None: all), without a profile or with one
    of ``profiles``."""
    return tuple(r for r in RULES if (kind is None or r.kind == kind)
                 and (r.profile is None or r.profile in profiles))


def rule_table_markdown() -> str:
    """The rule table of docs/compliance.md, generated from :data:`RULES`."""
    lines = ["| rule | FMI 2.0 section | severity | calls / XML | passes when |", "|---|---|---|---|---|"]
    for r in RULES:
        sev = r.severity + (f" (profile `{r.profile}`: error)" if r.profile else "")
        lines.append(f"| `{r.id}` | {r.section} | {sev} | {r.calls} | {r.summary} |")
    return "\n".join(lines)
