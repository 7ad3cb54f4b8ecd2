//! A generated variable table as the generic instance sees it. Every FMU's table is generated
//! by model_description with the same shape (`Var`, `VarInfo`, `Params`, `Inputs`, `Outputs`,
//! `Calculated`, `Locals`, each with `get_real`/`set_real`... by `Var`); `rig_table!` states that
//! shape once as the traits below, for a table module.

/// A variable's FMI type (the names are the table's, for messages).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    Real,
    Integer,
    Boolean,
    String,
}

/// A variable's causality (the names are the table's, for messages).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    Parameter,
    CalculatedParameter,
    Input,
    Output,
    Local,
}

/// What the instance needs to know of one variable.
#[derive(Clone, Copy, Debug)]
pub struct Info {
    pub name: &'static str,
    pub vr: u32,
    pub kind: Kind,
    pub role: Role,
    /// A fixed parameter: it cannot be set after initialization.
    pub fixed: bool,
}

/// A table: its variables and the structs that hold their values. Implemented by `rig_table!`
/// for a marker type (which makes the impls local to the FMU's crate).
pub trait Table: 'static {
    type Var: Copy + std::fmt::Debug + PartialEq + 'static;
    type Params: Values<Self> + Clone + Default + PartialEq + std::fmt::Debug;
    type Inputs: Values<Self> + Clone + Default + PartialEq + std::fmt::Debug;
    type Outputs: Values<Self> + Clone + Default + std::fmt::Debug;
    type Calculated: Values<Self> + Default;
    type Locals: Values<Self> + Default;
    fn from_vr(vr: u32) -> Option<Self::Var>;
    fn info(v: Self::Var) -> Info;
}

/// The values of one struct of the table, by variable (`None`/false: not in this struct or of
/// another type).
pub trait Values<T: Table + ?Sized> {
    fn get_real(&self, v: T::Var) -> Option<f64>;
    fn get_integer(&self, v: T::Var) -> Option<i32>;
    fn get_boolean(&self, v: T::Var) -> Option<bool>;
    fn get_string(&self, v: T::Var) -> Option<&str>;
    fn set_real(&mut self, v: T::Var, x: f64) -> bool;
    fn set_integer(&mut self, v: T::Var, x: i32) -> bool;
    fn set_boolean(&mut self, v: T::Var, x: bool) -> bool;
    fn set_string(&mut self, v: T::Var, x: String) -> bool;
    /// The first Real that is NaN or infinite, with its name.
    fn first_non_finite(&self) -> Option<(&'static str, f64)>;
}

/// A value type of fmi2Get*: how to read it from a struct of the table.
pub trait Scalar: Sized {
    const KIND: Kind;
    fn get<T: Table + ?Sized>(s: &impl Values<T>, v: T::Var) -> Option<Self>;
}

impl Scalar for f64 {
    const KIND: Kind = Kind::Real;
    #[inline(always)]
    fn get<T: Table + ?Sized>(s: &impl Values<T>, v: T::Var) -> Option<f64> {
        s.get_real(v)
    }
}

impl Scalar for i32 {
    const KIND: Kind = Kind::Integer;
    fn get<T: Table + ?Sized>(s: &impl Values<T>, v: T::Var) -> Option<i32> {
        s.get_integer(v)
    }
}

impl Scalar for bool {
    const KIND: Kind = Kind::Boolean;
    fn get<T: Table + ?Sized>(s: &impl Values<T>, v: T::Var) -> Option<bool> {
        s.get_boolean(v)
    }
}

impl Scalar for String {
    const KIND: Kind = Kind::String;
    fn get<T: Table + ?Sized>(s: &impl Values<T>, v: T::Var) -> Option<String> {
        s.get_string(v).map(str::to_owned)
    }
}

/// Implements `Table` for the marker type `$table` from the generated table module `$vars`
/// (`$vars::Var`, `$vars::Params`...).
#[macro_export]
macro_rules! rig_table {
    (@values $table:ty, $vars:path: $($s:ident)*) => {$(
        impl $crate::table::Values<$table> for $s {
            #[inline(always)]
            fn get_real(&self, v: Var) -> Option<f64> { $s::get_real(self, v) }
            fn get_integer(&self, v: Var) -> Option<i32> { $s::get_integer(self, v) }
            fn get_boolean(&self, v: Var) -> Option<bool> { $s::get_boolean(self, v) }
            fn get_string(&self, v: Var) -> Option<&str> { $s::get_string(self, v) }
            #[inline(always)]
            fn set_real(&mut self, v: Var, x: f64) -> bool { $s::set_real(self, v, x) }
            fn set_integer(&mut self, v: Var, x: i32) -> bool { $s::set_integer(self, v, x) }
            fn set_boolean(&mut self, v: Var, x: bool) -> bool { $s::set_boolean(self, v, x) }
            fn set_string(&mut self, v: Var, x: String) -> bool { $s::set_string(self, v, x) }
            fn first_non_finite(&self) -> Option<(&'static str, f64)> { $s::first_non_finite(self) }
        }
    )*};

    ($table:ident, $vars:path) => {
        /// The variable table as `rig_fmu` sees it.
        #[derive(Clone, Copy, Debug, PartialEq)]
        pub struct $table;

        const _: () = {
            use $vars::{Calculated, Causality, Inputs, Locals, Outputs, Params, Var, VarType, Variability};
            $crate::rig_table!(@values $table, $vars: Params Inputs Outputs Calculated Locals);

            impl $crate::table::Table for $table {
                type Var = Var;
                type Params = Params;
                type Inputs = Inputs;
                type Outputs = Outputs;
                type Calculated = Calculated;
                type Locals = Locals;
                #[inline(always)]
                fn from_vr(vr: u32) -> Option<Var> {
                    Var::from_vr(vr)
                }
                #[inline(always)]
                fn info(v: Var) -> $crate::table::Info {
                    use $crate::table::{Kind, Role};
                    let i = v.info();
                    $crate::table::Info {
                        name: i.name,
                        vr: i.vr,
                        kind: match i.ty {
                            VarType::Real => Kind::Real,
                            VarType::Integer => Kind::Integer,
                            VarType::Boolean => Kind::Boolean,
                            VarType::String => Kind::String,
                        },
                        role: match i.causality {
                            Causality::Parameter => Role::Parameter,
                            Causality::CalculatedParameter => Role::CalculatedParameter,
                            Causality::Input => Role::Input,
                            Causality::Output => Role::Output,
                            Causality::Local => Role::Local,
                        },
                        fixed: matches!(i.variability, Variability::Fixed),
                    }
                }
            }
        };
    };
}
