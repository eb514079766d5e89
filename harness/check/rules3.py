"""The FMI 3.0 rules of the compliance kit, as data (see :mod:`.rules` for the fields and the severities).

Kinds ``static3`` (modelDescription.xml and archive), ``cs3`` (co-simulation call sequence) and ``me3``
(model exchange). Every quote was checked against SOURCE_FMI3 (the rendering fmi-standard.org publishes
of the FMI 3.0 asciidoc of modelica/fmi-standard); "..." marks text left out, [...] is the standard's
own non-normative note.
"""
from __future__ import annotations

from .ruledef import ERROR, WARNING, Rule

SOURCE_FMI3 = ("modelica/fmi-standard.org, docs/3.0/index.html at commit d4b021e9fbf8ad57e15d75210abecb900e0290d3 "
               "(FMI 3.0 asciidoc of modelica/fmi-standard rendered by Asciidoctor; header 'version 3.0, 2022-05-10')")


def R(*args, **kw) -> Rule:
    return Rule(*args, fmi="3.0", **kw)


Q_ILLEGAL = ("2.2.4 fmi3Error: ... When detecting illegal arguments or a function call not allowed in the current state "
             "according to the respective state machine, the FMU must return fmi3Error.")
Q_TOKEN = ("2.4.1 instantiationToken: The instantiationToken is a string that may be used by the FMU to check that the XML "
           "file is compatible with the implementation of the FMU. For this purpose the importer must pass the "
           "instantiationToken from the modelDescription.xml to the fmi3InstantiateXXX function call.")

RULES3: tuple[Rule, ...] = (
    # ------------------------------------------------------------------ static (no binary)
    R("static3.archive", "2.5, 2.5.1", ERROR, "zip archive",
      "a readable zip within the kit's limits whose member names are relative, '/'-separated, without '..', ':' or "
      "'\\', with modelDescription.xml at its root",
      quote="2.5: An FMU consists of several files, that are stored in a ZIP file with a pre-defined structure. 2.5.1: "
            "modelDescription.xml // description of FMU (required file)"),
    R("static3.fmi3", "2.4.1", ERROR, "fmiModelDescription @fmiVersion, @instantiationToken, interface elements",
      'fmiVersion "3.x", a non-empty instantiationToken, and a ModelExchange, CoSimulation or ScheduledExecution '
      "element with a modelIdentifier",
      quote="fmiVersion: Version of FMI the XML file complies with. The value for this version is 3.0. ... At least one "
            "element of <ModelExchange>, <CoSimulation> or <ScheduledExecution> must be present to identify the type of "
            "the FMU. (2.3.1: ... stored in the xml file as mandatory attribute instantiationToken)"),
    R("static3.schema", "2.4", ERROR, "modelDescription.xml against fmi3ModelDescription.xsd",
      "modelDescription.xml is valid against the FMI 3.0 schema (the schema files fmpy ships)",
      quote="All static information related to the core functionality of an FMU is stored in the text file "
            "modelDescription.xml in XML format as specified by the XML schema file fmi3ModelDescription.xsd."),
    R("static3.binary", "2.5, 2.2.2", WARNING, "binaries/<platform tuple>/",
      "binaries/<platform tuple>/<modelIdentifier><ext> exists for the platform the kit runs on (else nothing can run "
      "here; an FMU may ship sources or other platforms' binaries only, so this is a warning)",
      quote="2.5: The FMU must be distributed with at least one implementation, in other words, either sources or one "
            "of the binaries for a particular machine. 2.2.2: The name of the library must be MyModel.dll on Windows "
            "or MyModel.so on Linux; in other words the modelIdentifier attribute is used as library name."),
    R("static3.variables", "2.4.7.4, 2.4", ERROR, "ModelVariables: @name, @valueReference, types, independent",
      "names unique and non-empty, value references unique, exactly one independent variable (a float without "
      "start), continuous variability only on Float32/Float64, Clocks discrete",
      quote="2.4: name attributes of list elements (for example VariableType or Variable) must be unique within that "
            "list and must not be empty strings. 2.4.7.4 valueReference: The valueReference must be unique for all "
            "variables of an FMU. independent: ... Exactly one variable of an FMU must be defined as independent. ... "
            "The independent variable must be defined as a floating point type without a start attribute. continuous: "
            "Only variables of type <Float32> or <Float64> may be continuous. ... The variability of Clocks must be "
            "discrete."),
    R("static3.causality-variability", "2.4.7.4", ERROR, "@causality, @variability",
      "every variable's causality/variability combination is one of Table 18",
      quote="Allowed combinations of causality and variability and their semantics are defined in Table 18. (Table 18: "
            "constant: output, local; fixed and tunable: structuralParameter, parameter, calculatedParameter, local; "
            "discrete: input, output, local; continuous: input, output, local, independent)"),
    R("static3.initial", "2.4.7.5", ERROR, "@initial, @start",
      "initial is one Table 22 allows for the variable's causality/variability; a start value is there where "
      "initial is exact or approx, for parameters, inputs and constants, and absent where initial is calculated and "
      "on the independent variable (a combination Table 18 refuses is static3.causality-variability's finding)",
      quote="Table 22 defines the allowed values for initial as combination of causality and variability and the "
            "default value if initial is not present. ... If initial = exact or approx, a start attribute must be "
            "provided. If initial = calculated or causality = independent, it is not allowed to provide a start "
            "attribute. Variables with causality = parameter or input, as well as variables with variability = "
            "constant, must have a start attribute"),
    R("static3.units", "2.4.7.5, 2.4.4", ERROR, "@unit, @displayUnit against UnitDefinitions",
      "every unit (of a variable or its declared type) is a Unit of UnitDefinitions, every displayUnit a DisplayUnit of "
      "that unit, and a displayUnit comes with a unit",
      quote="unit: This attribute defines the unit of the variable by referencing a <UnitDefinitions><Unit> with the "
            "same name, which must exist. ... displayUnit: Default display unit of the variable referencing to a "
            "<DisplayUnit> which must exist under <UnitDefinitions><Unit> with the name of unit. ... If displayUnit "
            "is defined a unit must also be defined."),
    R("static3.outputs", "2.4.8", ERROR, "ModelStructure/Output, ModelStructure/ContinuousStateDerivative",
      "ModelStructure/Output lists every output exactly once and nothing else; every ContinuousStateDerivative names a "
      "variable with a derivative attribute pointing to a float variable",
      quote="Output: Ordered list of all outputs, in other words, a list of value references where every corresponding "
            "variable must have causality = output (and every variable with causality = output must be listed here). "
            "... 2.4.7.5 derivative: ... All variables listed in these elements must have attribute derivative."),
    R("static3.initial-unknowns", "2.4.8", ERROR, "ModelStructure/InitialUnknown",
      "InitialUnknown lists, once each, the non-clocked outputs and the continuous-time states and state derivatives "
      "with initial approx or calculated, and the calculated parameters (clocked variables the FMU chooses to list "
      "are allowed), and no event indicator only",
      quote="InitialUnknown: Ordered list of all exposed unknowns in Initialization Mode. This list consists of all "
            "variables which: are not clocked variables and have causality = output (with initial = approx or "
            "calculated), or have causality = calculatedParameter, or are continuous-time states or state derivatives "
            "(defined with elements <ContinuousStateDerivative>) with initial = approx or calculated, or are clocked "
            "variables that the FMU wishes to initialize in initialization mode. The resulting list is not allowed to "
            "have duplicates"),
    R("static3.dimensions", "2.4.7.2, 2.4.7.4", ERROR, "Dimension @start, @valueReference",
      "every Dimension has exactly one of start and valueReference; a valueReference names a UInt64 constant or "
      "structural parameter; every initial size is a positive integer; a structural parameter has no Dimension",
      quote="2.4.7.2: The referenced variable must be a variable of type <UInt64>, and must either be a constant (i.e. "
            "with variability = constant) or a structural parameter (i.e. with causality = structuralParameter). ... "
            "for each <Dimension> element either a start attribute or a valueReference attribute can be supplied, but "
            "not both. ... All initial dimension sizes ... must be positive integers (i.e. not zero) 2.4.7.4: A "
            "structural parameter must not have a <Dimension> element."),
    R("static3.start-range", "2.4.4", WARNING, "@start, @min, @max (and declaredType)",
      "every start value (each element of an array's) lies within the variable's min and max (its own, else its "
      "declared type's); min and max are defined, not commanded, and a start outside them contradicts them: a "
      "warning",
      quote="min: Minimum value of variable (variable value ≥ min). ... The min defines the region in which the FMU is "
            "designed to operate (see Section 2.2.7.3). max: Maximum value of variable (variable value ≤ max).",
      groups=("values",)),
    # ------------------------------------------------------------------ co-simulation
    R("cs3.basic", "4.2, 2.3.1", ERROR,
      "fmi3InstantiateCoSimulation, fmi3Set* (start values), fmi3EnterInitializationMode, fmi3ExitInitializationMode, "
      "fmi3DoStep, fmi3Get*, fmi3Terminate, fmi3FreeInstance",
      "the basic call sequence (--steps doSteps of the DefaultExperiment step, event mode and early return not used) "
      "is accepted",
      quote="4.2: The state machine in Figure 42 defines the allowed calling sequences for FMI for Co-Simulation. 2.3.1: "
            "These functions return a new instance of an FMU with the respective interface type. If a NULL pointer is "
            "returned, then instantiation failed."),
    R("cs3.version", "2.2.5", ERROR, "fmi3GetVersion",
      'fmi3GetVersion returns "3.0"',
      quote="This function returns fmi3Version of the fmi3Functions.h header file which was used to compile the "
            "functions of the FMU. This function call is allowed always and in all interface types. The standard header "
            "file as documented in this specification has version 3.0, so this function returns 3.0."),
    R("cs3.instantiation-token", "2.4.1, 2.3.1", WARNING, "fmi3InstantiateCoSimulation(instantiationToken)",
      "fmi3InstantiateCoSimulation with a token other than the modelDescription's returns NULL; the FMU \"may\" check "
      "the token (no shall/must): a warning",
      quote=Q_TOKEN),
    R("cs3.initial-unknowns", "2.4.8, 2.3.3", ERROR, "fmi3Get* in Initialization Mode",
      "in Initialization Mode the outputs and the InitialUnknowns can be read",
      quote="2.4.8: Since, outputs, continuous-time states and state derivatives are either present as knowns (if "
            "initial = exact) or as unknowns (if initial = approx or calculated), they can be inquired with "
            "fmi3Get{VariableType} in Initialization Mode. 2.3.3 (Allowed Function Calls): Functions "
            "fmi3Get{VariableType}: Getting variables might trigger computations."),
    R("cs3.stop-time", "2.3.2", ERROR, "fmi3EnterInitializationMode(stopTimeDefined), fmi3DoStep",
      "with the stop time defined, a doStep past it is refused with fmi3Error (refusing with fmi3Discard: warning)",
      quote="If stopTimeDefined = fmi3True, then stopTime is the final value of the independent variable and inherits "
            "its unit. If the environment tries to compute past stopTime, the FMU has to return fmi3Status = "
            "fmi3Error.", groups=("experiment", "discard")),
    R("cs3.get-after-terminate", "2.3.8", ERROR, "fmi3Terminate, fmi3Get*",
      "after fmi3Terminate the outputs can still be read",
      quote="In this state, the final values of all variables at the final time of a simulation can be retrieved. ... "
            "Allowed Function Calls: Functions fmi3Get{VariableType}"),
    R("cs3.reset", "2.3.1", ERROR, "fmi3Reset",
      "after fmi3Reset the same run gives the same outputs",
      quote="fmi3Reset: Is called by the environment to reset the FMU after a simulation run. The FMU goes into the "
            "same state as if fmi3InstantiateXXX would have been called. All variables have their default values.",
      groups=("instances",)),
    R("cs3.get-set-state", "2.2.7.4, 2.4.2", ERROR, "fmi3GetFMUState, fmi3SetFMUState, fmi3FreeFMUState",
      "(canGetAndSetFMUState) after fmi3SetFMUState the outputs are the saved ones, the continuation repeats the first "
      "one, and a second restore of the same state does too",
      quote="fmi3GetFMUState: This function copies the internal FMU state and returns a pointer to this copy in "
            "FMUState. FMUState must contain all information required to allow continuing the simulation from the "
            "current FMU state without additional FMI C-API calls. ... fmi3SetFMUState: This function restores the "
            "state provided by FMUState. The FMU must not change the content of the provided FMUState to allow "
            "multiple calls of fmi3SetFMUState with this FMUState.", groups=("state",)),
    R("cs3.step-before-init", "2.2.4, 4.2", ERROR, "fmi3DoStep in Instantiated",
      "a doStep before initialization (the state machine does not allow it) is refused with fmi3Error; refused with "
      "another status: error; accepted: a warning (the sentence binds an FMU that detects the call)",
      quote=Q_ILLEGAL, groups=("steps",)),
    R("cs3.zero-step-size", "4.2.1, 2.2.4", ERROR, "fmi3DoStep(communicationStepSize = 0)",
      "a doStep with communicationStepSize = 0 (it must be > 0) is refused with fmi3Error; refused with another "
      "status: error; accepted: a warning (the sentence binds an FMU that detects the illegal argument)",
      quote="4.2.1: communicationStepSize is the communication step size (h_i). communicationStepSize must be > 0.0. "
            + Q_ILLEGAL, groups=("steps",)),
    R("cs3.default-experiment", "2.4.6, 4.2.1", WARNING, "fmi3EnterInitializationMode(stopTimeDefined), fmi3DoStep",
      "a run from the DefaultExperiment start to its stop time at its step size, with the stop time defined, is "
      "accepted and its Float64 outputs stay finite (at most half the rule's timeout and 1,000,000 steps, then it "
      "says how much it checked); 2.4.6 asks for a meaningful default, not a run that works: a warning",
      quote="2.4.6: <DefaultExperiment> consists of the optional default start time, stop time, relative tolerance, and "
            "step size for a simulation run. A tool may ignore this information. [However, it is convenient for a user "
            "that startTime, stopTime, tolerance and stepSize have already a meaningful default value for the model at "
            "hand.] Furthermore, for Co-Simulation FMUs the stepSize defines the preferred communicationStepSize.",
      groups=("experiment",)),
    R("cs3.output-derivative-orders", "4.1.2, 2.2.4", ERROR, "fmi3GetOutputDerivatives(orders = 0, max + 1)",
      "(maxOutputDerivativeOrder >= 1) after a doStep, fmi3GetOutputDerivatives of a continuous Float64 output with "
      "order 0 and with order maxOutputDerivativeOrder + 1 is refused with fmi3Error; refused with another status: "
      "error; accepted: a warning (the sentence binds an FMU that detects the illegal argument)",
      quote="4.1.2: Whether the FMU is able to provide the derivatives of outputs is given by the capability flag "
            "maxOutputDerivativeOrder that represents the maximum order of the output derivatives. ... orders "
            "contains the orders of the respective derivative (1 means the first derivative, 2 means the second "
            "derivative, ..., 0 is not allowed). " + Q_ILLEGAL, groups=("derivatives",)),
    R("cs3.output-derivatives", "4.1.2", WARNING, "fmi3DoStep, fmi3GetOutputDerivatives(orders = 1)",
      "(maxOutputDerivativeOrder >= 1) after a doStep the first derivatives of the continuous Float64 outputs are "
      "given and finite; an output refused is named (4.1.2 says they \"may be retrieved\", no shall: a warning)",
      quote="4.1.2: In FMI for Co-Simulation, the n-th derivatives with respect to time of continuous outputs may "
            "be retrieved with fmi3GetOutputDerivatives, for example, to allow interpolation/extrapolation of "
            "connected input variables between communication points by the importer. ... The returned values "
            "correspond to the derivatives at the current time of the FMU.", groups=("derivatives",)),
    R("cs3.early-return-not-allowed", "4.2.1, 4.1.3", ERROR, "fmi3InstantiateCoSimulation(earlyReturnAllowed = "
      "false), fmi3DoStep",
      "(mightReturnEarlyFromDoStep) instantiated with earlyReturnAllowed = false, no doStep of the default experiment "
      "(within half the rule's timeout) returns earlyReturn = true, and each reaches t + h",
      quote="4.2.1: earlyReturn signals to the importer that the FMU returns at t_{i+1} < t_i + communicationStepSize. "
            "earlyReturn = fmi3True is only allowed if earlyReturnAllowed = fmi3True in fmi3InstantiateCoSimulation. "
            "4.1.3: The argument earlyReturnAllowed of fmi3InstantiateCoSimulation signals to the FMU if the "
            "importer allows early return.", groups=("early",)),
    R("cs3.early-return-time", "4.2.1", ERROR, "fmi3InstantiateCoSimulation(earlyReturnAllowed = true), fmi3DoStep",
      "(mightReturnEarlyFromDoStep) instantiated with earlyReturnAllowed = true, over the default experiment (within "
      "half the rule's timeout, the importer going on from each lastSuccessfulTime): a doStep with earlyReturn = true "
      "has t_i <= lastSuccessfulTime < t_i + h (t_i + h to rounding accepted: an event on the step's end), and the "
      "doStep from there is accepted",
      quote="4.2.1: earlyReturn signals to the importer that the FMU returns at t_{i+1} < t_i + communicationStepSize. "
            "... The time reached is specified in lastSuccessfulTime. ... lastSuccessfulTime represents the internal "
            "time t_{i+1} of the FMU when fmi3DoStep returns, for any value of earlyReturn. It is possible that the "
            "lastSuccessfulTime is equal to currentCommunicationPoint when earlyReturn = fmi3True ...",
      groups=("early",)),
    # ------------------------------------------------------------------ model exchange
    R("me3.basic", "3.2, 2.3.5", ERROR,
      "fmi3InstantiateModelExchange, fmi3EnterInitializationMode, fmi3ExitInitializationMode, fmi3UpdateDiscreteStates, "
      "fmi3EnterContinuousTimeMode, fmi3SetTime, fmi3Get/SetContinuousStates, fmi3GetContinuousStateDerivatives, "
      "fmi3GetEventIndicators, fmi3CompletedIntegratorStep, fmi3EnterEventMode, fmi3Terminate, fmi3FreeInstance",
      "the model-exchange call sequence, driven by explicit Euler at the DefaultExperiment step to its stop time with "
      "event iteration at state, time and step events, is accepted; states and derivatives finite",
      quote="3.2: The state machine in Figure 40 defines the allowed calling sequences for FMI for Model Exchange. 2.3.5 "
            "fmi3EnterContinuousTimeMode: This function must be called to change from Event Mode into Continuous-Time "
            "Mode in Model Exchange."),
    R("me3.instantiation-token", "2.4.1, 2.3.1", WARNING, "fmi3InstantiateModelExchange(instantiationToken)",
      "fmi3InstantiateModelExchange with a token other than the modelDescription's returns NULL; the FMU \"may\" "
      "check the token (no shall/must): a warning",
      quote=Q_TOKEN),
)
