//! `export_fmi3!`: the exported C functions of FMI 3.0.

/// Defines, in the invoking module, every function of FMI 3.0 (`fmi3Functions.h`) as
/// `#[no_mangle] extern "C"` for the model type given, each calling its body in
/// `fmi3_slave::ffi` or fmi2-slave's. Invoke it once per FMU binary, beside `export_fmi2!`:
/// the fmi2* and fmi3* names do not collide, so one binary serves both FMUs.
///
/// ```ignore
/// fmi3_slave::export_fmi3!(crate::fmi::instance::SpurGearMesh);
/// ```
#[macro_export]
macro_rules! export_fmi3 {
    // Get/set of the variable types the model has none of: (instance, vrs, nvr, values, nvalues).
    (@none $slave:ty: $($name:ident($value:ty) => $ty:literal;)*) => {$(
        #[no_mangle]
        pub unsafe extern "C" fn $name(
            c: $crate::Fmi3Instance,
            vr: *const $crate::Fmi3ValueReference,
            n_vr: usize,
            _values: $value,
            _n_values: usize,
        ) -> $crate::Fmi3Status {
            $crate::ffi::no_such_type::<$slave>(c, stringify!($name), $ty, vr, n_vr)
        }
    )*};

    // Typed values: (instance, vrs, nvr, values, nvalues).
    (@values $slave:ty: $($name:ident($value:ty) => $body:ident;)*) => {$(
        #[no_mangle]
        pub unsafe extern "C" fn $name(
            c: $crate::Fmi3Instance,
            vr: *const $crate::Fmi3ValueReference,
            n_vr: usize,
            values: $value,
            n_values: usize,
        ) -> $crate::Fmi3Status {
            $crate::ffi::$body::<$slave>(c, vr, n_vr, values, n_values)
        }
    )*};

    // Capabilities the model does not have: any arguments, fmi3Error with the reason.
    (@unsupported $slave:ty: $($name:ident($($arg:ident: $t:ty),*) => $why:literal;)*) => {$(
        #[no_mangle]
        pub unsafe extern "C" fn $name(c: $crate::Fmi3Instance $(, $arg: $t)*) -> $crate::Fmi3Status {
            $(let _ = $arg;)*
            $crate::ffi::not_supported::<$slave>(c, stringify!($name), $why)
        }
    )*};

    // Model Exchange's arrays: (instance, array, size), fmi2-slave's bodies.
    (@me_arrays $slave:ty: $($name:ident => $body:ident;)*) => {$(
        #[no_mangle]
        pub unsafe extern "C" fn $name(c: $crate::Fmi3Instance, x: *mut f64, n: usize) -> $crate::Fmi3Status {
            ::fmi2_slave::model_exchange::$body::<$slave>(c, x, n)
        }
    )*};

    ($slave:ty) => {
        #[no_mangle]
        pub extern "C" fn fmi3GetVersion() -> *const ::std::os::raw::c_char {
            $crate::ffi::get_version()
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetDebugLogging(
            c: $crate::Fmi3Instance,
            on: bool,
            n: usize,
            categories: *const *const ::std::os::raw::c_char,
        ) -> $crate::Fmi3Status {
            $crate::ffi::set_debug_logging::<$slave>(c, on, n, categories)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3InstantiateModelExchange(
            name: *const ::std::os::raw::c_char,
            token: *const ::std::os::raw::c_char,
            resource_path: *const ::std::os::raw::c_char,
            _visible: bool,
            logging_on: bool,
            env: $crate::Fmi3InstanceEnvironment,
            log_message: $crate::Fmi3LogMessageCallback,
        ) -> $crate::Fmi3Instance {
            $crate::ffi::instantiate::<$slave>(
                "fmi3InstantiateModelExchange", name, token, resource_path, true, false, logging_on, env, log_message,
            )
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3InstantiateCoSimulation(
            name: *const ::std::os::raw::c_char,
            token: *const ::std::os::raw::c_char,
            resource_path: *const ::std::os::raw::c_char,
            _visible: bool,
            logging_on: bool,
            event_mode_used: bool,
            _early_return_allowed: bool,
            _required_intermediate: *const $crate::Fmi3ValueReference,
            _n_required_intermediate: usize,
            env: $crate::Fmi3InstanceEnvironment,
            log_message: $crate::Fmi3LogMessageCallback,
            _intermediate_update: $crate::Fmi3IntermediateUpdateCallback,
        ) -> $crate::Fmi3Instance {
            $crate::ffi::instantiate::<$slave>(
                "fmi3InstantiateCoSimulation", name, token, resource_path, false, event_mode_used, logging_on, env,
                log_message,
            )
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3InstantiateScheduledExecution(
            _name: *const ::std::os::raw::c_char,
            _token: *const ::std::os::raw::c_char,
            _resource_path: *const ::std::os::raw::c_char,
            _visible: bool,
            _logging_on: bool,
            env: $crate::Fmi3InstanceEnvironment,
            log_message: $crate::Fmi3LogMessageCallback,
            _clock_update: $crate::Fmi3ClockUpdateCallback,
            _lock_preemption: $crate::Fmi3LockPreemptionCallback,
            _unlock_preemption: $crate::Fmi3UnlockPreemptionCallback,
        ) -> $crate::Fmi3Instance {
            $crate::ffi::instantiate_scheduled::<$slave>(env, log_message)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3FreeInstance(c: $crate::Fmi3Instance) {
            ::fmi2_slave::ffi::free_instance::<$slave>(c)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3EnterInitializationMode(
            c: $crate::Fmi3Instance,
            tolerance_defined: bool,
            tolerance: f64,
            start_time: f64,
            stop_time_defined: bool,
            stop_time: f64,
        ) -> $crate::Fmi3Status {
            $crate::ffi::enter_initialization_mode::<$slave>(
                c, tolerance_defined, tolerance, start_time, stop_time_defined, stop_time,
            )
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3ExitInitializationMode(c: $crate::Fmi3Instance) -> $crate::Fmi3Status {
            ::fmi2_slave::ffi::exit_initialization_mode::<$slave>(c)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3EnterEventMode(c: $crate::Fmi3Instance) -> $crate::Fmi3Status {
            ::fmi2_slave::model_exchange::enter_event_mode::<$slave>(c)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3Terminate(c: $crate::Fmi3Instance) -> $crate::Fmi3Status {
            ::fmi2_slave::ffi::terminate::<$slave>(c)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3Reset(c: $crate::Fmi3Instance) -> $crate::Fmi3Status {
            ::fmi2_slave::ffi::reset::<$slave>(c)
        }

        $crate::export_fmi3!(@values $slave:
            fmi3GetFloat64(*mut f64) => get_float64;
            fmi3SetFloat64(*const f64) => set_float64;
            fmi3GetInt32(*mut i32) => get_int32;
            fmi3SetInt32(*const i32) => set_int32;
            fmi3GetBoolean(*mut bool) => get_boolean;
            fmi3SetBoolean(*const bool) => set_boolean;
            fmi3GetString(*mut *const ::std::os::raw::c_char) => get_string;
            fmi3SetString(*const *const ::std::os::raw::c_char) => set_string;
        );

        $crate::export_fmi3!(@none $slave:
            fmi3GetFloat32(*mut f32) => "Float32";
            fmi3SetFloat32(*const f32) => "Float32";
            fmi3GetInt8(*mut i8) => "Int8";
            fmi3SetInt8(*const i8) => "Int8";
            fmi3GetUInt8(*mut u8) => "UInt8";
            fmi3SetUInt8(*const u8) => "UInt8";
            fmi3GetInt16(*mut i16) => "Int16";
            fmi3SetInt16(*const i16) => "Int16";
            fmi3GetUInt16(*mut u16) => "UInt16";
            fmi3SetUInt16(*const u16) => "UInt16";
            fmi3GetUInt32(*mut u32) => "UInt32";
            fmi3SetUInt32(*const u32) => "UInt32";
            fmi3GetInt64(*mut i64) => "Int64";
            fmi3SetInt64(*const i64) => "Int64";
            fmi3GetUInt64(*mut u64) => "UInt64";
            fmi3SetUInt64(*const u64) => "UInt64";
        );

        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetBinary(
            c: $crate::Fmi3Instance,
            vr: *const $crate::Fmi3ValueReference,
            n_vr: usize,
            _sizes: *mut usize,
            _values: *mut *const u8,
            _n_values: usize,
        ) -> $crate::Fmi3Status {
            $crate::ffi::no_such_type::<$slave>(c, "fmi3GetBinary", "Binary", vr, n_vr)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetBinary(
            c: $crate::Fmi3Instance,
            vr: *const $crate::Fmi3ValueReference,
            n_vr: usize,
            _sizes: *const usize,
            _values: *const *const u8,
            _n_values: usize,
        ) -> $crate::Fmi3Status {
            $crate::ffi::no_such_type::<$slave>(c, "fmi3SetBinary", "Binary", vr, n_vr)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetClock(
            c: $crate::Fmi3Instance,
            vr: *const $crate::Fmi3ValueReference,
            n_vr: usize,
            _values: *mut bool,
        ) -> $crate::Fmi3Status {
            $crate::ffi::no_such_type::<$slave>(c, "fmi3GetClock", "Clock", vr, n_vr)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetClock(
            c: $crate::Fmi3Instance,
            vr: *const $crate::Fmi3ValueReference,
            n_vr: usize,
            _values: *const bool,
        ) -> $crate::Fmi3Status {
            $crate::ffi::no_such_type::<$slave>(c, "fmi3SetClock", "Clock", vr, n_vr)
        }

        // ---- FMU states (fmi2-slave's; the bytes are fmi3Byte) ------------------------------

        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetFMUState(
            c: $crate::Fmi3Instance,
            state: *mut $crate::Fmi3FMUState,
        ) -> $crate::Fmi3Status {
            ::fmi2_slave::ffi::get_fmu_state::<$slave>(c, state)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetFMUState(
            c: $crate::Fmi3Instance,
            state: $crate::Fmi3FMUState,
        ) -> $crate::Fmi3Status {
            ::fmi2_slave::ffi::set_fmu_state::<$slave>(c, state)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3FreeFMUState(
            c: $crate::Fmi3Instance,
            state: *mut $crate::Fmi3FMUState,
        ) -> $crate::Fmi3Status {
            ::fmi2_slave::ffi::free_fmu_state::<$slave>(c, state)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3SerializedFMUStateSize(
            c: $crate::Fmi3Instance,
            state: $crate::Fmi3FMUState,
            size: *mut usize,
        ) -> $crate::Fmi3Status {
            ::fmi2_slave::ffi::serialized_fmu_state_size::<$slave>(c, state, size)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3SerializeFMUState(
            c: $crate::Fmi3Instance,
            state: $crate::Fmi3FMUState,
            buf: *mut u8,
            size: usize,
        ) -> $crate::Fmi3Status {
            ::fmi2_slave::ffi::serialize_fmu_state::<$slave>(c, state, buf as *mut _, size)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3DeserializeFMUState(
            c: $crate::Fmi3Instance,
            buf: *const u8,
            size: usize,
            state: *mut $crate::Fmi3FMUState,
        ) -> $crate::Fmi3Status {
            ::fmi2_slave::ffi::deserialize_fmu_state::<$slave>(c, buf as *const _, size, state)
        }

        // ---- Model Exchange ----------------------------------------------------------------

        #[no_mangle]
        pub unsafe extern "C" fn fmi3EvaluateDiscreteStates(c: $crate::Fmi3Instance) -> $crate::Fmi3Status {
            $crate::ffi::evaluate_discrete_states::<$slave>(c)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3UpdateDiscreteStates(
            c: $crate::Fmi3Instance,
            need_update: *mut bool,
            terminate: *mut bool,
            nominals_changed: *mut bool,
            values_changed: *mut bool,
            next_event_time_defined: *mut bool,
            next_event_time: *mut f64,
        ) -> $crate::Fmi3Status {
            $crate::ffi::update_discrete_states::<$slave>(
                c, need_update, terminate, nominals_changed, values_changed,
                next_event_time_defined, next_event_time,
            )
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3EnterContinuousTimeMode(c: $crate::Fmi3Instance) -> $crate::Fmi3Status {
            ::fmi2_slave::model_exchange::enter_continuous_time_mode::<$slave>(c)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3CompletedIntegratorStep(
            c: $crate::Fmi3Instance,
            _no_set_prior: bool,
            enter_event_mode: *mut bool,
            terminate: *mut bool,
        ) -> $crate::Fmi3Status {
            $crate::ffi::completed_integrator_step::<$slave>(c, enter_event_mode, terminate)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetDirectionalDerivative(
            c: $crate::Fmi3Instance,
            unknowns: *const $crate::Fmi3ValueReference,
            n_unknowns: usize,
            knowns: *const $crate::Fmi3ValueReference,
            n_knowns: usize,
            seed: *const f64,
            n_seed: usize,
            sensitivity: *mut f64,
            n_sensitivity: usize,
        ) -> $crate::Fmi3Status {
            ::fmi2_slave::model_exchange::get_directional_derivative::<$slave>(
                c,
                "fmi3GetDirectionalDerivative",
                unknowns,
                n_unknowns,
                knowns,
                n_knowns,
                (seed, n_seed),
                (sensitivity, n_sensitivity),
            )
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetTime(c: $crate::Fmi3Instance, time: f64) -> $crate::Fmi3Status {
            ::fmi2_slave::model_exchange::set_time::<$slave>(c, time)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3SetContinuousStates(
            c: $crate::Fmi3Instance,
            x: *const f64,
            nx: usize,
        ) -> $crate::Fmi3Status {
            ::fmi2_slave::model_exchange::set_continuous_states::<$slave>(c, x, nx)
        }

        $crate::export_fmi3!(@me_arrays $slave:
            fmi3GetContinuousStateDerivatives => get_derivatives;
            fmi3GetEventIndicators => get_event_indicators;
            fmi3GetContinuousStates => get_continuous_states;
            fmi3GetNominalsOfContinuousStates => get_nominals_of_continuous_states;
        );

        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetNumberOfEventIndicators(
            c: $crate::Fmi3Instance,
            n: *mut usize,
        ) -> $crate::Fmi3Status {
            let count = <$slave as ::fmi2_slave::Slave>::n_event_indicators;
            $crate::ffi::get_number::<$slave>(c, "fmi3GetNumberOfEventIndicators", count, n)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi3GetNumberOfContinuousStates(
            c: $crate::Fmi3Instance,
            n: *mut usize,
        ) -> $crate::Fmi3Status {
            let count = <$slave as ::fmi2_slave::Slave>::n_states;
            $crate::ffi::get_number::<$slave>(c, "fmi3GetNumberOfContinuousStates", count, n)
        }

        // ---- Co-Simulation -----------------------------------------------------------------

        #[no_mangle]
        pub unsafe extern "C" fn fmi3DoStep(
            c: $crate::Fmi3Instance,
            current: f64,
            h: f64,
            _no_set_prior: bool,
            event_handling_needed: *mut bool,
            terminate: *mut bool,
            early_return: *mut bool,
            last_successful_time: *mut f64,
        ) -> $crate::Fmi3Status {
            $crate::ffi::do_step::<$slave>(
                c, current, h, event_handling_needed, terminate, early_return, last_successful_time,
            )
        }

        $crate::export_fmi3!(@unsupported $slave:
            fmi3GetNumberOfVariableDependencies(_vr: $crate::Fmi3ValueReference, _n: *mut usize)
                => "dependencies are not provided beyond modelDescription.xml";
            fmi3GetVariableDependencies(
                _dependent: $crate::Fmi3ValueReference,
                _element_indices: *mut usize,
                _independents: *mut $crate::Fmi3ValueReference,
                _independent_indices: *mut usize,
                _kinds: *mut $crate::Fmi3DependencyKind,
                _n: usize
            ) => "dependencies are not provided beyond modelDescription.xml";
            fmi3GetAdjointDerivative(
                _unknowns: *const $crate::Fmi3ValueReference,
                _n_unknowns: usize,
                _knowns: *const $crate::Fmi3ValueReference,
                _n_knowns: usize,
                _seed: *const f64,
                _n_seed: usize,
                _sensitivity: *mut f64,
                _n_sensitivity: usize
            ) => "providesAdjointDerivatives is false";
            fmi3EnterConfigurationMode() => "the FMU has no structural parameters";
            fmi3ExitConfigurationMode() => "the FMU has no structural parameters";
            fmi3GetIntervalDecimal(
                _vr: *const $crate::Fmi3ValueReference,
                _n: usize,
                _intervals: *mut f64,
                _qualifiers: *mut $crate::Fmi3IntervalQualifier
            ) => "the FMU has no clocks";
            fmi3GetIntervalFraction(
                _vr: *const $crate::Fmi3ValueReference,
                _n: usize,
                _counters: *mut u64,
                _resolutions: *mut u64,
                _qualifiers: *mut $crate::Fmi3IntervalQualifier
            ) => "the FMU has no clocks";
            fmi3GetShiftDecimal(_vr: *const $crate::Fmi3ValueReference, _n: usize, _shifts: *mut f64)
                => "the FMU has no clocks";
            fmi3GetShiftFraction(
                _vr: *const $crate::Fmi3ValueReference,
                _n: usize,
                _counters: *mut u64,
                _resolutions: *mut u64
            ) => "the FMU has no clocks";
            fmi3SetIntervalDecimal(_vr: *const $crate::Fmi3ValueReference, _n: usize, _intervals: *const f64)
                => "the FMU has no clocks";
            fmi3SetIntervalFraction(
                _vr: *const $crate::Fmi3ValueReference,
                _n: usize,
                _counters: *const u64,
                _resolutions: *const u64
            ) => "the FMU has no clocks";
            fmi3SetShiftDecimal(_vr: *const $crate::Fmi3ValueReference, _n: usize, _shifts: *const f64)
                => "the FMU has no clocks";
            fmi3SetShiftFraction(
                _vr: *const $crate::Fmi3ValueReference,
                _n: usize,
                _counters: *const u64,
                _resolutions: *const u64
            ) => "the FMU has no clocks";
            fmi3EnterStepMode()
                => "hasEventMode is false: the instance is in Step Mode after initialization";
            fmi3GetOutputDerivatives(
                _vr: *const $crate::Fmi3ValueReference,
                _n: usize,
                _orders: *const i32,
                _values: *mut f64,
                _n_values: usize
            ) => "maxOutputDerivativeOrder is 0";
            fmi3ActivateModelPartition(_clock: $crate::Fmi3ValueReference, _time: f64)
                => "the FMU has no Scheduled Execution interface";
        );
    };
}
