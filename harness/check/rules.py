"""The rules of the compliance kit, as data: id, FMI version and section, severity, calls, what is checked.
The FMI 2.0 rules are here; the FMI 3.0 rules (kinds static3, cs3, me3) in :mod:`.rules3`; an FMU gets the
rules of its fmiVersion (:func:`fmi_version`, :func:`applies`).

Severity comes from the standard's own words (FMI 2.0.x, "Functional Mock-up Interface for Model
Exchange and Co-Simulation"; FMI 3.0, "Functional Mock-up Interface Specification"):

``error``
    the standard says *shall* / *must* / *has to* / *needs to*, or the call sequence is one the
    standard requires to work (3.2.3: "Every implementation of the FMI must support calling
    sequences of the functions according to the following state chart"; 4.2.4: "The following
    state machine defines the supported calling sequences"; 2.3: "An FMU has to implement all
    common functions (according to tables in sections 3.2.3 and 4.2.4)");
``warning``
    the standard says *should* / *is recommended*, or a sentence without *shall* / *must* (a
    definition, a permission), or the behaviour is left undefined (a call outside the allowed
    states, a step size the master must not use: 3.2.3 "The behaviour of an FMU is undefined for
    such a calling sequence") and a robust FMU still handles it by refusing;
``info``
    good practice, and the conventions of a profile (``--profile``): the standard does not ask
    for them. A rule with a ``profile`` runs only when that profile is selected, and then its
    failures count as errors (the profile makes them requirements).

Exit code: 1 when any rule of severity error failed (``--strict``: or a warning), else 0.
The kinds: ``static`` (modelDescription.xml and archive, no binary loaded), ``cs`` (the
co-simulation call sequence, each rule in a fresh process), ``me`` (model exchange, likewise).
"""
from __future__ import annotations

from .ruledef import ERROR, INFO, PROFILES, SEVERITIES, WARNING, Rule  # noqa: F401  (re-exported)


R = Rule
# The quotes: FMI 2.0, checked sentence by sentence against the Asciidoctor rendering of the FMI 2.0.x
# asciidoc that fmi-standard.org publishes (SOURCE_FMI2); "..." marks text left out, [...] is the
# standard's own non-normative note. A rule with quote=None has no sentence of the standard behind it:
# it is never an error.
SOURCE_FMI2 = ("modelica/fmi-standard.org, docs/2.0.1-develop/index.html at commit "
               "3f33b06837359c3cf71981ad412096e3eded8c8a (FMI 2.0.x asciidoc of modelica/fmi-standard rendered by "
               "Asciidoctor 1.5.7.1; header 'version 2.0, July 25, 2014')")
Q_STATE_MACHINE_CS = ("4.2.4: The following state machine defines the supported calling sequences. ... The allowed "
                      "function calls in the respective states are summarized in the following table ...; 2.3: An FMU "
                      "has to implement all common functions (according to tables in sections 3.2.3 and 4.2.4).")
Q_GUID = ("Argument fmuGUID is used to check that the modelDescription.xml file (see section 2.3) is compatible with the "
          "C code of the FMU. ... It must be identical to the one stored inside the fmi2Instantiate function. Otherwise "
          "the C code and the XML file of the FMU are not consistent to each other. (2.1.5: If a null pointer is "
          "returned, then instantiation failed.)")
Q_STEP_SIZE = ("Argument currentCommunicationPoint is the current communication point of the master (tc_i) and argument "
               "communicationStepSize is the communication step size (hc_i). The latter must be > 0.0.")
RULES: tuple[Rule, ...] = (
    # ------------------------------------------------------------------ static (no binary)
    R("static.archive", "2.3", ERROR, "zip archive",
      "a readable zip within the kit's limits (members, unpacked size, modelDescription.xml size) whose "
      "member names are relative, '/'-separated, without '..', ':' or '\\', with modelDescription.xml at its root",
      quote="All relevant files are stored in a zip file with a pre-defined structure."),
    R("static.fmi2", "2.2.1", ERROR, "fmiModelDescription",
      'fmiVersion="2.0" and a CoSimulation or ModelExchange element with a modelIdentifier',
      quote='2.2.1 fmiVersion: Version of "FMI for Model Exchange or Co-Simulation" that was used to generate the '
            'XML file. The value for this version is "2.0". ... At least one element of ModelExchange or CoSimulation '
            'must be present to identify the type of the FMU.'),
    R("static.fmpy-validate", "2.2", ERROR, "modelDescription.xml",
      "fmpy.validation.validate_fmu: XML schema, unique names, ModelStructure, start values, "
      "causality/variability/initial combinations, units against UnitDefinitions",
      quote='2.2.8 InitialUnknowns: Ordered list of all exposed Unknowns in Initialization Mode. This list consists '
            'of all variables with 1. causality = "output" and (initial = "approx" or "calculated"), and 2. causality = '
            '"calculatedParameter" and 3. all continuous-time states and all state derivatives (defined with element '
            '<Derivatives> from <ModelStructure>) with initial = "approx" or "calculated"; 2.2.7: If initial = "exact" '
            'or "approx" or causality = "input", a start value must be provided. (the rest: the schema, 2.2: The '
            'normative definition are the above mentioned schema files)'),
    R("static.binary", "2.3", WARNING, "binaries/<platform>/",
      "binaries/<platform>/<modelIdentifier><ext> exists for the platform the kit runs on (else nothing can run "
      "here; FMI 2.0 lets an FMU ship sources or other platforms' binaries only, so this is a warning)",
      quote="The FMU must be distributed with at least one implementation, in other words either sources or one of "
            "the binaries for a particular machine."),
    R("static.names", "2.2.7, 2.2.9", ERROR, "ScalarVariable/@name",
      'names legal for variableNamingConvention ("structured": the grammar of 2.2.9; "flat": no CR, LF, tab)',
      quote='2.2.7 name: The full, unique name of the variable. 2.2.9 flat: The names must be unique, non-empty '
            'strings. structured: ... The precise syntax is: name = identifier | "der(" identifier [","  '
            'unsignedInteger ] ")" ...'),
    R("static.model-exchange", "2.2.1, 2.2.7, 2.2.8", ERROR, "ModelExchange, ModelStructure/Derivatives",
      "each ModelStructure/Derivatives entry names a continuous Real derivative of a continuous Real state; "
      "numberOfEventIndicators is a non-negative integer",
      quote="2.2.8 Derivatives: Ordered list of all state derivatives, in other words a list of ScalarVariable "
            "indices where every corresponding ScalarVariable must be a state derivative. ... The corresponding "
            "continuous-time states are defined by attribute derivative of the corresponding ScalarVariable state "
            "derivative element. 2.2.7: All ScalarVariables listed in this element must have attribute derivative"),
    R("static.start-range", "2.2.3, 2.2.7", WARNING, "Real/Integer/Enumeration @start, @min, @max (and declaredType)",
      "every start value lies within the variable's min and max (its own, else its declaredType's); min and max "
      "are defined, not commanded (no shall/must), and a start outside them contradicts them: a warning",
      quote="2.2.3 min: Minimum value of variable (variable Value ≥ min). ... The min definition is an information "
            "from the FMU to the environment defining the region in which the FMU is designed to operate ... max: "
            "Maximum value of variable (variableValue ≤ max). 2.2.7 start: ... If causality = \"parameter\", the "
            "start-value is the value of it.", groups=("values",)),
    R("static.output-dependencies", "2.2.8", INFO, "ModelStructure/Outputs/@dependencies",
      "outputs of an FMU with inputs declare their dependencies (without, an importer must assume direct "
      "feedthrough from every input; good practice, not required)",
      quote="dependencies: Optional attribute ... If not present, it must be assumed that the Unknown depends on all "
            "Knowns."),
    R("static.units", "2.2.3", INFO, "Real/@unit",
      'every Real has a unit or a declaredType with one (unit="1" for dimensionless)', profile="spurdiff",
      groups=("conventions",)),
    R("static.descriptions", "2.2.7", INFO, "ScalarVariable/@description",
      "every variable has a description", profile="spurdiff", groups=("conventions",)),
    R("static.all-output-dependencies", "2.2.8", INFO, "ModelStructure/Outputs/@dependencies",
      "every output declares its dependencies, also without inputs", profile="spurdiff", groups=("conventions",)),
    # ------------------------------------------------------------------ the binary outside Python
    R("load.needed-libraries", "2.3", WARNING, "ELF: undefined dynamic symbols, DT_NEEDED, DT_RUNPATH",
      "every undefined symbol of binaries/<platform>/<modelIdentifier>.so is defined by a library it declares "
      "(DT_NEEDED, searched the way the dynamic loader does); otherwise it loads only into a process that happens "
      "to have that library already (e.g. libm in Python). No sentence of FMI 2.0 says it: a warning",
      groups=("load",)),
    R("load.bare-process", "2.3, 4.2.4", WARNING, "dlopen, fmi2Instantiate, fmi2SetupExperiment, "
      "fmi2Enter/ExitInitializationMode, fmi2DoStep, fmi2Terminate, fmi2FreeInstance (from C)",
      "a small C host, compiled with cc when the kit runs, opens the binary (dlopen RTLD_NOW) in a bare "
      "environment (env -i), instantiates, initializes, steps 3 times and frees it (model exchange only: "
      "initializes and frees). No sentence of FMI 2.0 names a host process: a warning",
      groups=("load",)),
    # ------------------------------------------------------------------ co-simulation
    R("cs.version", "2.1.4, 2.1.2", ERROR, "fmi2GetVersion, fmi2GetTypesPlatform",
      'fmi2GetVersion returns "2.0"; fmi2GetTypesPlatform "default" (the standard header\'s types: only recommended, '
      'so another value is a warning)',
      quote='2.1.4 fmi2GetVersion: Returns the version of the "fmi2Functions.h" header file which was used to compile '
            'the functions of the FMU. The function returns "fmiVersion" which is defined in this header file. The '
            'standard header file as documented in this specification has version "2.0" ...; 2.1.2: It is '
            'recommended to use this "default" definition for all binary FMUs.'),
    R("cs.basic", "4.2.4, 2.3", ERROR,
      "fmi2Instantiate, fmi2SetupExperiment, fmi2Enter/ExitInitializationMode, fmi2DoStep, fmi2Get*, fmi2Terminate, fmi2FreeInstance",
      "the basic call sequence (--steps doSteps of the DefaultExperiment step) is accepted",
      quote=Q_STATE_MACHINE_CS),
    R("cs.guid", "2.1.5", ERROR, "fmi2Instantiate",
      "fmi2Instantiate with a GUID other than the modelDescription's returns NULL",
      quote=Q_GUID),
    R("cs.logger", "2.1.5", ERROR, "fmi2CallbackLogger",
      "every message reaches the logger with the componentEnvironment given to fmi2Instantiate and the "
      "instance's name",
      quote="Additionally, a pointer to the environment is provided (componentEnvironment) that needs to be passed "
            "to the logger function, in order that the logger function can utilize data from the environment, such as "
            "mapping a valueReference to a string. ... \"instanceName\" is the instance name of the model that calls "
            "this function."),
    R("cs.debug-logging", "2.1.5", ERROR, "fmi2SetDebugLogging",
      "fmi2SetDebugLogging with the declared LogCategories, with none (all) and off is accepted",
      quote="If loggingOn=fmi2True, debug logging is enabled, otherwise it is switched off. If loggingOn=fmi2True and "
            "nCategories > 0, then only debug messages according to the categories argument shall be printed via the "
            "logger function. (4.2.4 table: fmi2SetDebugLogging is allowed in every state but start, end and fatal)"),
    R("cs.initial-unknowns", "4.2.4, 2.2.8", ERROR, "fmi2Get* in initialization mode",
      "in initialization mode the InitialUnknowns, outputs with initial exact/approx and calculated parameters "
      "can be read",
      quote='4.2.4 Initialization Mode: The variables that can be retrieved by fmi2GetXXX calls are (1) defined in the '
            'xml file under <ModelStructure><InitialUnknowns> and (2) variables with causality = "output". 2.2.8: Since '
            'outputs, continuous-time states and state derivatives are either present as Knowns (if initial = "exact") '
            'or as Unknowns (if initial = "approx" or "calculated"), they can be inquired with fmiGetXXX in '
            'InitializationMode. 2.3: An FMU has to implement all common functions (according to tables in sections '
            '3.2.3 and 4.2.4).'),
    R("cs.default-experiment", "2.2.5, 4.2.2", WARNING, "fmi2SetupExperiment(stopTimeDefined), fmi2DoStep",
      "a run from the DefaultExperiment start to its stop time at its step size, with the stop time "
      "defined, is accepted and its Real outputs stay finite; the run stops at a step cap and a time budget "
      "(half the rule's timeout) and then says how much of the experiment it checked. 2.2.5 asks for a "
      "meaningful default, not a run that works (no shall/must), and fmi2Error is a status a step may return: "
      "a warning",
      quote="2.2.5: DefaultExperiment consists of the optional default start time, stop time, relative tolerance, and "
            "step size for the first simulation run. A tool may ignore this information. However, it is convenient "
            "for a user that startTime, stopTime, tolerance and stepSize have already a meaningful default value for "
            "the model at hand. Furthermore, for CoSimulation the stepSize defines the preferred "
            "communicationStepSize.", groups=("experiment",)),
    R("cs.stop-time", "2.1.6", ERROR, "fmi2SetupExperiment(stopTimeDefined), fmi2DoStep",
      "with the stop time defined, a doStep past it is refused with fmi2Error (refusing with fmi2Discard: warning)",
      quote="If stopTimeDefined = fmi2True, then stopTime is the defined final value of the independent variable "
            "[...] and if the environment tries to compute past stopTime the FMU has to return fmi2Status = "
            "fmi2Error.",
      groups=("experiment", "discard")),
    R("cs.status-after-discard", "4.2.3", ERROR,
      "fmi2GetStatus, fmi2GetRealStatus(fmi2LastSuccessfulTime), fmi2GetBooleanStatus(fmi2Terminated)",
      "precondition: a doStep was discarded (past the stop time in cs.stop-time, in cs.default-experiment, or "
      "with NaN inputs in cs.nan-inputs; else SKIP). That discard is repeated and the status calls answer "
      "(fmi2Discard for a status the slave cannot give, never fmi2Error/Fatal) and fmi2LastSuccessfulTime lies "
      "within the refused step",
      quote="4.2.3: If a status is required which cannot be retrieved by the slave it returns fmi2Discard. ... "
            "fmi2LastSuccessfulTime: Returns the end time of the last successfully completed communication step. Can "
            "be called after fmi2DoStep returned fmi2Discard. fmi2Terminated: Returns true, if the slave wants to "
            "terminate the simulation. Can be called after fmi2DoStep returned fmi2Discard.", groups=("discard",)),
    R("cs.get-after-terminate", "2.1.6, 4.2.4", ERROR, "fmi2Terminate, fmi2Get*",
      "after fmi2Terminate the outputs can still be read (state terminated allows fmi2Get*)",
      quote="2.1.6 fmi2Terminate: Informs the FMU that the simulation run is terminated. After calling this function, "
            "the final values of all variables can be inquired with the fmi2GetXXX(..) functions. 4.2.4 terminated: In "
            "this state, the solution at the final time of the simulation can be retrieved. (table: fmi2GetReal, "
            "fmi2GetInteger, fmi2GetBoolean, fmi2GetString x in state terminated) 2.3: An FMU has to implement all "
            "common functions (according to tables in sections 3.2.3 and 4.2.4)."),
    R("cs.reset", "2.1.6", ERROR, "fmi2Reset",
      "after fmi2Reset the same run gives the same outputs",
      quote="fmi2Reset: Is called by the environment to reset the FMU after a simulation run. The FMU goes into "
            "the same state as if fmi2Instantiate would have been called. All variables have their default values.",
      groups=("instances",)),
    R("cs.two-instances", "2.1.5, 2.1", ERROR, "fmi2Instantiate x 2",
      "two instances at once each give the outputs they give alone (unless canBeInstantiatedOnlyOncePerProcess)",
      quote="2.1.5: An FMU can be instantiated many times (provided capability flag "
            "canBeInstantiatedOnlyOncePerProcess = false). 2.1: FMI functions must not change global settings which "
            "affects other processes/threads. ... [So functions of different FMU instances can be called safely in "
            "any order. ...]",
      groups=("instances",)),
    R("cs.get-set-state", "2.1.8", ERROR, "fmi2GetFMUstate, fmi2SetFMUstate",
      "(canGetAndSetFMUstate) after fmi2SetFMUstate the outputs are the saved ones and the continuation repeats "
      "the first one; a continuation that differs by no more than the bound from the FMU's tolerance, while two "
      "restores agree, is integrator history the state leaves out: a warning giving the difference",
      quote="fmi2GetFMUstate makes a copy of the internal FMU state and returns a pointer to this copy (FMUstate). "
            "... fmi2SetFMUstate copies the content of the previously copied FMUstate back and uses it as actual "
            "new FMU state. The FMUstate copy does still exist.", groups=("state",)),
    R("cs.free-state", "2.1.8", ERROR, "fmi2GetFMUstate, fmi2SetFMUstate, fmi2FreeFMUstate",
      "(canGetAndSetFMUstate; precondition: cs.get-set-state restores a state) a state set twice gives the same "
      "continuation both times, fmi2GetFMUstate overwrites a given state, fmi2FreeFMUstate succeeds and sets the "
      "pointer to NULL, freeing NULL is ignored",
      quote="If *FMUstate != NULL, then *FMUstate points to a previously returned FMUstate that has not been "
            "modified since. ... "
            "fmi2FreeFMUstate frees all memory and other resources allocated with the fmi2GetFMUstate call for "
            "this FMUstate. ... If a null pointer is provided, the call is ignored. The function returns a null "
            "pointer in argument FMUstate.", groups=("state",)),
    R("cs.serialize-state", "2.1.8", ERROR, "fmi2SerializeFMUstate, fmi2DeSerializeFMUstate",
      "(canSerializeFMUstate; precondition: cs.get-set-state restores a state) a serialized state restored into a "
      "fresh instance continues as the same state restored with fmi2SetFMUstate",
      quote="fmi2DeSerializeFMUstate deserializes the byte vector serializedState of length size, constructs a copy "
            "of the FMU state and returns FMUstate, the pointer to this copy. [The simulation is restarted at this "
            "state, when calling fmi2SetFMUState with FMUstate.]", groups=("state",)),
    R("cs.variable-step", "4.3.1", ERROR, "fmi2DoStep",
      "(canHandleVariableCommunicationStepSize) varying step sizes are accepted, outputs stay finite",
      quote="canHandleVariableCommunicationStepSize: The slave can handle variable communication step size. The "
            "communication step size (parameter communicationStepSize of fmi2DoStep) has not to be constant for "
            "each call.", groups=("steps",)),
    R("cs.clock", "4.2.2", ERROR, "fmi2DoStep(currentCommunicationPoint, communicationStepSize)",
      "(canHandleVariableCommunicationStepSize) --steps steps of h, and the same steps each split into 0.618 h + "
      "0.382 h, give the same outputs at every communication point, within twice the largest difference of "
      "uniform steps of h from uniform steps of 2 h and h/2, plus 10 x the FMU's tolerance of the output's "
      "magnitude; an output that moves with steps of h but not at all with steps of h/2 fails: the FMU keeps "
      "its own clock",
      quote="The slave must integrate until time instant tc_{i+1} = tc_i + hc_i. [The calling environment defines "
            "the communication points and fmi2DoStep must synchronize to these points by always integrating exactly "
            "to tc_i + hc_i. It is up to fmi2DoStep how to achieve this.]", groups=("steps",)),
    R("cs.feedthrough", "2.2.8, 4.2.4", INFO, "fmi2SetReal (inputs), fmi2GetReal (outputs) at one communication point",
      "after a step, each Real input is changed and every Real output that declares a dependency on it is read "
      "again at the same communication point: it changes, unless it does not change after the next step either "
      "(insensitive here). An output that changes only after the next step is stale. 4.2.4 forbids the master "
      "exactly this sequence in slaveInitialized (fmi2GetXXX after fmi2SetXXX without fmi2DoStep), so the FMU may "
      "answer anything: good practice (a master resolving an algebraic loop needs it), never more than info",
      quote="2.2.8 Unknown: It is assumed that ... at a Communication Point (CoSimulation) the following relationship "
            "holds: v_unknown = h(v_known, v_freeze) ... Attribute dependencies of Unknown defines the dependency of "
            "v_unknown with respect to v_known. 4.2.4: There is the additional restriction in slaveInitialized state "
            "that it is not allowed to call fmi2GetXXX functions after fmi2SetXXX functions without an fmi2DoStep "
            "call in between.", groups=("io",)),
    R("cs.interpolate-inputs", "4.3.1, 4.2.1", ERROR, "fmi2SetRealInputDerivatives",
      "(canInterpolateInputs) first derivatives of the Real inputs are accepted",
      quote="canInterpolateInputs: The slave is able to interpolate continuous inputs. Calling of "
            "fmi2SetRealInputDerivatives has an effect for the slave.", groups=("io",)),
    R("cs.output-derivatives", "4.3.1, 4.2.1", ERROR, "fmi2GetRealOutputDerivatives",
      "(maxOutputDerivativeOrder >= 1) first derivatives of the Real outputs are given, finite",
      quote="maxOutputDerivativeOrder: The slave is able to provide derivatives of outputs with maximum order. Calling "
            "of fmi2GetRealOutputDerivatives is allowed up to the order defined by maxOutputDerivativeOrder.",
      groups=("io",)),
    R("cs.directional-derivative", "4.3.1, 2.1.9", ERROR, "fmi2GetDirectionalDerivative",
      "(providesDirectionalDerivative) derivatives of the outputs with respect to the Real inputs after a "
      "step (without inputs: of the InitialUnknowns with respect to their dependencies, in initialization "
      "mode) are given, finite",
      quote="4.3.1 providesDirectionalDerivative: If true, the directional derivative of the equations at "
            "communication points can be computed with fmi2GetDirectionalDerivative.", groups=("io",)),
    R("cs.step-before-init", "4.2.4", WARNING, "fmi2DoStep",
      "a doStep before initialization (not allowed in state instantiated) is refused; the standard forbids the "
      "call but does not say what the FMU returns: a warning",
      quote="4.2.4: The following state machine defines the supported calling sequences. (table: fmi2DoStep is not "
            "allowed in state instantiated); 3.2.3: Calling sequences not accepted by the state chart are not supported "
            "by the FMI. The behaviour of an FMU is undefined for such a calling sequence.", groups=("steps",)),
    R("cs.zero-step-size", "4.2.2", WARNING, "fmi2DoStep",
      "a doStep with communicationStepSize = 0 (it must be > 0) is refused; the sentence binds the master, not "
      "what the FMU returns: a warning",
      quote=Q_STEP_SIZE,
      groups=("steps",)),
    R("cs.negative-step-size", "4.2.2", WARNING, "fmi2DoStep",
      "a doStep with a negative communicationStepSize (it must be > 0) is refused; the sentence binds the master: "
      "a warning",
      quote=Q_STEP_SIZE,
      groups=("steps",)),
    R("cs.nan-inputs", "2.1.7", INFO, "fmi2SetReal, fmi2DoStep",
      "NaN on the Real inputs is refused or shows in the outputs, not silently ignored (good practice: no "
      "sentence of FMI 2.0 mentions NaN, so never more than info)", groups=("io", "discard")),
    R("cs.parameter-after-init", "2.2.7, 4.2.4", INFO, "fmi2SetReal/Integer/Boolean after initialization",
      "a fixed parameter set after initialization (not allowed then; behaviour undefined) is refused",
      profile="spurdiff", groups=("conventions",)),
    # ------------------------------------------------------------------ model exchange
    R("me.basic", "3.2.3", ERROR,
      "fmi2Instantiate(fmi2ModelExchange), fmi2SetupExperiment, fmi2Enter/ExitInitializationMode, "
      "fmi2NewDiscreteStates, fmi2EnterContinuousTimeMode, fmi2SetTime, fmi2Get/SetContinuousStates, "
      "fmi2GetDerivatives, fmi2GetEventIndicators, fmi2CompletedIntegratorStep, fmi2EnterEventMode, "
      "fmi2Terminate, fmi2FreeInstance",
      "the model-exchange call sequence, driven by explicit Euler at the DefaultExperiment step to its stop "
      "time with event iteration at state, time and step events, is accepted; states and derivatives finite",
      quote="3.2.3: Every implementation of the FMI must support calling sequences of the functions according to the "
            "following state chart: ... The allowed function calls in the respective states are summarized in the "
            "following table ..."),
    R("me.directional-derivative", "3.3.1, 2.1.9", ERROR, "fmi2GetDirectionalDerivative, fmi2GetDerivatives",
      "(providesDirectionalDerivative) in continuous-time mode the state Jacobian (derivatives with respect to "
      "the states) is given and matches central differences of fmi2GetDerivatives within 1e-4 (relative)",
      quote="3.3.1 providesDirectionalDerivative: If true, the directional derivative of the equations can be "
            "computed with fmi2GetDirectionalDerivative(..); 2.1.9: If the capability attribute "
            "\"providesDirectionalDerivative\" is true, fmi2GetDirectionalDerivative computes a linear combination of "
            "the partial derivatives of h with respect to the selected input variables v_known", groups=("io",)),
    R("me.guid", "2.1.5", ERROR, "fmi2Instantiate(fmi2ModelExchange)",
      "fmi2Instantiate with a GUID other than the modelDescription's returns NULL",
      quote=Q_GUID),
)

from .rules3 import RULES3, SOURCE_FMI3  # noqa: E402,F401  (FMI 3.0 rules, SOURCE_FMI3 re-exported)

RULES2: tuple[Rule, ...] = RULES
RULES = RULES2 + RULES3
BY_ID: dict[str, Rule] = {r.id: r for r in RULES}
KINDS = {"2.0": ("static", "load", "cs", "me"), "3.0": ("static3", "cs3", "me3")}


def fmi_version(fmi_version_attribute: str | None) -> str:
    """The rule set an FMU gets from its modelDescription's fmiVersion: "3.0" for 3.x, else "2.0"."""
    return "3.0" if (fmi_version_attribute or "").strip().startswith("3") else "2.0"


def applies(rule: Rule, version: str) -> bool:
    """Whether ``rule`` checks FMUs of FMI ``version`` ("2.0" / "3.0")."""
    return rule.fmi == version


def rules(kind: str | None = None, profiles: tuple[str, ...] = ()) -> tuple[Rule, ...]:
    """The rules that run: of ``kind`` (static / cs / me; None: all), without a profile or with one
    of ``profiles``."""
    return tuple(r for r in RULES if (kind is None or r.kind == kind)
                 and (r.profile is None or r.profile in profiles))


def rule_table_markdown() -> str:
    """The rule table of docs/compliance.md, generated from :data:`RULES`."""
    lines = ["| rule | groups | FMI section | severity | calls / XML | passes when | the standard's words |",
             "|---|---|---|---|---|---|---|"]
    for r in RULES:
        sev = r.severity + (f" (profile `{r.profile}`: error)" if r.profile else "")
        quote = (f"\"{r.quote}\"" if r.quote else f"(no sentence of FMI {r.fmi}: "
                 + ("a convention)" if r.profile else "never an error)"))
        groups = ", ".join(f"`{g}`" for g in (r.kind,) + r.groups)
        lines.append(f"| `{r.id}` | {groups} | {r.fmi}: {r.section} | {sev} | {r.calls} | {r.summary} | {quote} |"
                     .replace("\\", "\\\\"))
    return "\n".join(lines)


TABLE_BEGIN = "<!-- rule table: generated by `spurdiff check --write-rule-table docs/compliance.md` -->"
TABLE_END = "<!-- end of the rule table -->"


def with_rule_table(text: str) -> str:
    """``text`` (docs/compliance.md) with the part between TABLE_BEGIN and TABLE_END replaced by
    :func:`rule_table_markdown` (ValueError when the markers are missing)."""
    i, j = text.find(TABLE_BEGIN), text.find(TABLE_END)
    if i < 0 or j < i:
        raise ValueError(f"no {TABLE_BEGIN} ... {TABLE_END} block")
    return text[:i + len(TABLE_BEGIN)] + "\n" + rule_table_markdown() + "\n" + text[j:]
