//! `export_fmi2!`: the exported C functions of FMI 2.0.

/// Defines, in the invoking module, every function of FMI 2.0 (`fmi2Functions.h`: 44 functions)
/// as `#[no_mangle] extern "C"` for the model type given, each calling its generic body in
/// `fmi2_slave::ffi`. Invoke it once per FMU binary (a cdylib exports exactly one model):
///
/// ```ignore
/// fmi2_slave::export_fmi2!(crate::fmi::instance::SpurGearMesh);
/// ```
///
/// The signatures are those of the standard's headers (checked by tests/python/test_abi.py).
#[macro_export]
macro_rules! export_fmi2 {
    // fmi2Get* and fmi2Set* of Real, Integer, Boolean: (component, vr, n, value array).
    (@values $slave:ty: $($name:ident($value:ty) => $body:ident;)*) => {$(
        #[no_mangle]
        pub unsafe extern "C" fn $name(
            c: $crate::Component,
            vr: *const $crate::ValueReference,
            n: usize,
            value: $value,
        ) -> $crate::Status {
            $crate::ffi::$body::<$slave>(c, vr, n, value)
        }
    )*};

    // fmi2Get*Status: (component, status kind, value).
    (@status $slave:ty: $($name:ident($value:ty) => $body:ident;)*) => {$(
        #[no_mangle]
        pub unsafe extern "C" fn $name(
            c: $crate::Component,
            kind: $crate::StatusKind,
            value: $value,
        ) -> $crate::Status {
            $crate::ffi::$body::<$slave>(c, kind, value)
        }
    )*};

    // Model Exchange: each function calls its body in `fmi2_slave::model_exchange`, which
    // answers fmi2Error for a Co-Simulation-only model (no instance can be in its states).
    (@model_exchange $slave:ty) => {
        #[no_mangle]
        pub unsafe extern "C" fn fmi2EnterEventMode(c: $crate::Component) -> $crate::Status {
            $crate::model_exchange::enter_event_mode::<$slave>(c)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2NewDiscreteStates(
            c: $crate::Component,
            event_info: *mut $crate::EventInfo,
        ) -> $crate::Status {
            $crate::model_exchange::new_discrete_states::<$slave>(c, event_info)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2EnterContinuousTimeMode(c: $crate::Component) -> $crate::Status {
            $crate::model_exchange::enter_continuous_time_mode::<$slave>(c)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2CompletedIntegratorStep(
            c: $crate::Component,
            no_set_prior: $crate::Boolean,
            enter_event_mode: *mut $crate::Boolean,
            terminate: *mut $crate::Boolean,
        ) -> $crate::Status {
            $crate::model_exchange::completed_integrator_step::<$slave>(
                c,
                no_set_prior,
                enter_event_mode,
                terminate,
            )
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2SetTime(c: $crate::Component, time: f64) -> $crate::Status {
            $crate::model_exchange::set_time::<$slave>(c, time)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2SetContinuousStates(
            c: $crate::Component,
            x: *const f64,
            nx: usize,
        ) -> $crate::Status {
            $crate::model_exchange::set_continuous_states::<$slave>(c, x, nx)
        }

        $crate::export_fmi2!(@me_arrays $slave:
            fmi2GetDerivatives => get_derivatives;
            fmi2GetEventIndicators => get_event_indicators;
            fmi2GetContinuousStates => get_continuous_states;
            fmi2GetNominalsOfContinuousStates => get_nominals_of_continuous_states;
        );
    };

    // Model Exchange's getters: (component, array, size).
    (@me_arrays $slave:ty: $($name:ident => $body:ident;)*) => {$(
        #[no_mangle]
        pub unsafe extern "C" fn $name(c: $crate::Component, x: *mut f64, n: usize) -> $crate::Status {
            $crate::model_exchange::$body::<$slave>(c, x, n)
        }
    )*};

    ($slave:ty) => {
        #[no_mangle]
        pub extern "C" fn fmi2GetTypesPlatform() -> *const ::std::os::raw::c_char {
            $crate::ffi::get_types_platform()
        }

        #[no_mangle]
        pub extern "C" fn fmi2GetVersion() -> *const ::std::os::raw::c_char {
            $crate::ffi::get_version()
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2Instantiate(
            instance_name: *const ::std::os::raw::c_char,
            fmu_type: $crate::Type,
            guid: *const ::std::os::raw::c_char,
            resource_location: *const ::std::os::raw::c_char,
            functions: *const $crate::CallbackFunctions,
            _visible: $crate::Boolean,
            logging_on: $crate::Boolean,
        ) -> $crate::Component {
            $crate::ffi::instantiate::<$slave>(
                instance_name, fmu_type, guid, resource_location, functions, logging_on,
            )
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2FreeInstance(c: $crate::Component) {
            $crate::ffi::free_instance::<$slave>(c)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2SetDebugLogging(
            c: $crate::Component,
            on: $crate::Boolean,
            n: usize,
            categories: *const *const ::std::os::raw::c_char,
        ) -> $crate::Status {
            $crate::ffi::set_debug_logging::<$slave>(c, on, n, categories)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2SetupExperiment(
            c: $crate::Component,
            tolerance_defined: $crate::Boolean,
            tolerance: f64,
            start_time: f64,
            stop_time_defined: $crate::Boolean,
            stop_time: f64,
        ) -> $crate::Status {
            $crate::ffi::setup_experiment::<$slave>(
                c,
                tolerance_defined,
                tolerance,
                start_time,
                stop_time_defined,
                stop_time,
            )
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2EnterInitializationMode(c: $crate::Component) -> $crate::Status {
            $crate::ffi::enter_initialization_mode::<$slave>(c)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2ExitInitializationMode(c: $crate::Component) -> $crate::Status {
            $crate::ffi::exit_initialization_mode::<$slave>(c)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2Terminate(c: $crate::Component) -> $crate::Status {
            $crate::ffi::terminate::<$slave>(c)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2Reset(c: $crate::Component) -> $crate::Status {
            $crate::ffi::reset::<$slave>(c)
        }

        $crate::export_fmi2!(@values $slave:
            fmi2GetReal(*mut f64) => get_real;
            fmi2GetInteger(*mut ::std::os::raw::c_int) => get_integer;
            fmi2GetBoolean(*mut $crate::Boolean) => get_boolean;
            fmi2SetReal(*const f64) => set_real;
            fmi2SetInteger(*const ::std::os::raw::c_int) => set_integer;
            fmi2SetBoolean(*const $crate::Boolean) => set_boolean;
        );

        #[no_mangle]
        pub unsafe extern "C" fn fmi2GetString(
            c: $crate::Component,
            vr: *const $crate::ValueReference,
            n: usize,
            value: *mut *const ::std::os::raw::c_char,
        ) -> $crate::Status {
            $crate::ffi::get_string::<$slave>(c, vr, n, value)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2SetString(
            c: $crate::Component,
            vr: *const $crate::ValueReference,
            n: usize,
            value: *const *const ::std::os::raw::c_char,
        ) -> $crate::Status {
            $crate::ffi::set_string::<$slave>(c, vr, n, value)
        }

        // ---- FMU states ----------------------------------------------------------------------

        #[no_mangle]
        pub unsafe extern "C" fn fmi2GetFMUstate(
            c: $crate::Component,
            state: *mut $crate::FmuState,
        ) -> $crate::Status {
            $crate::ffi::get_fmu_state::<$slave>(c, state)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2SetFMUstate(
            c: $crate::Component,
            state: $crate::FmuState,
        ) -> $crate::Status {
            $crate::ffi::set_fmu_state::<$slave>(c, state)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2FreeFMUstate(
            c: $crate::Component,
            state: *mut $crate::FmuState,
        ) -> $crate::Status {
            $crate::ffi::free_fmu_state::<$slave>(c, state)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2SerializedFMUstateSize(
            c: $crate::Component,
            state: $crate::FmuState,
            size: *mut usize,
        ) -> $crate::Status {
            $crate::ffi::serialized_fmu_state_size::<$slave>(c, state, size)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2SerializeFMUstate(
            c: $crate::Component,
            state: $crate::FmuState,
            buf: *mut ::std::os::raw::c_char,
            size: usize,
        ) -> $crate::Status {
            $crate::ffi::serialize_fmu_state::<$slave>(c, state, buf, size)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2DeSerializeFMUstate(
            c: $crate::Component,
            buf: *const ::std::os::raw::c_char,
            size: usize,
            state: *mut $crate::FmuState,
        ) -> $crate::Status {
            $crate::ffi::deserialize_fmu_state::<$slave>(c, buf, size, state)
        }

        // ---- Co-Simulation -------------------------------------------------------------------

        #[no_mangle]
        pub unsafe extern "C" fn fmi2DoStep(
            c: $crate::Component,
            current: f64,
            h: f64,
            _no_set_prior: $crate::Boolean,
        ) -> $crate::Status {
            $crate::ffi::do_step::<$slave>(c, current, h)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2CancelStep(c: $crate::Component) -> $crate::Status {
            $crate::ffi::cancel_step::<$slave>(c)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2SetRealInputDerivatives(
            c: $crate::Component,
            vr: *const $crate::ValueReference,
            n: usize,
            order: *const ::std::os::raw::c_int,
            value: *const f64,
        ) -> $crate::Status {
            $crate::ffi::set_real_input_derivatives::<$slave>(c, vr, n, order, value)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2GetRealOutputDerivatives(
            c: $crate::Component,
            _vr: *const $crate::ValueReference,
            _n: usize,
            _order: *const ::std::os::raw::c_int,
            _value: *mut f64,
        ) -> $crate::Status {
            $crate::ffi::get_real_output_derivatives::<$slave>(c)
        }

        #[no_mangle]
        pub unsafe extern "C" fn fmi2GetDirectionalDerivative(
            c: $crate::Component,
            unknown: *const $crate::ValueReference,
            nu: usize,
            known: *const $crate::ValueReference,
            nk: usize,
            dv_known: *const f64,
            dv_unknown: *mut f64,
        ) -> $crate::Status {
            $crate::model_exchange::get_directional_derivative::<$slave>(
                c,
                "fmi2GetDirectionalDerivative",
                unknown,
                nu,
                known,
                nk,
                (dv_known, nk),
                (dv_unknown, nu),
            )
        }

        $crate::export_fmi2!(@status $slave:
            fmi2GetStatus(*mut $crate::Status) => get_status;
            fmi2GetRealStatus(*mut f64) => get_real_status;
            fmi2GetIntegerStatus(*mut ::std::os::raw::c_int) => get_integer_status;
            fmi2GetBooleanStatus(*mut $crate::Boolean) => get_boolean_status;
            fmi2GetStringStatus(*mut *const ::std::os::raw::c_char) => get_string_status;
        );

        $crate::export_fmi2!(@model_exchange $slave);
    };

}
