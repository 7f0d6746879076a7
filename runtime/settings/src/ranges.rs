//! [`ranges!`]: a section's range checks written as a list of `field: rule` beside the struct,
//! each key built from the field's name (`stringify!`) under the [`Checker`](crate::Checker)'s
//! table, so no key path is typed by hand.

/// An unsigned config value checked by [`Checker::count`](crate::Checker::count), as `usize`.
pub trait Count: Copy {
    /// The value as a count.
    fn as_count(self) -> usize;
}

macro_rules! counts {
    ($($t:ty),+) => {
        $(impl Count for $t {
            fn as_count(self) -> usize {
                self as usize
            }
        })+
    };
}
counts!(u8, u16, u32, u64, usize);

/// Range-check fields of a config section, in the order written; the first value out of range
/// returns its [`ConfigError::Range`](crate::ConfigError::Range) from the enclosing function
/// (`?`). `ranges!(c, s, { field: rule, ... })` checks `s.field` under the key
/// `c.key("field")`: the checker ([`Checker::at`](crate::Checker::at)) holds the table's dotted
/// key, the macro adds the field's name.
///
/// | rule | checks | error text |
/// |---|---|---|
/// | `in_range(lo, hi)` | finite, in `[lo, hi]` (as `f64`) | `must be in [lo, hi]` |
/// | `count(lo, hi)` | unsigned, in `[lo, hi]` (as `usize`) | `must be in [lo, hi]` |
/// | `within(lo, hi)` | in `[lo, hi]`, any ordered type (signed integers) | `must be in [lo, hi]` |
/// | `positive` | finite and `> 0` (as `f64`) | `must be a finite number > 0` |
/// | `require(ok, expected)` | the condition `ok` (cross-field rules) | `expected` |
/// | `section` | `s.field.validate(&c.at("field"))`: a nested table checks itself | its own |
///
/// `[a, b]: rule` applies one rule to several fields. A key that a rule's text or a hand-written
/// check needs is [`key!`](crate::key)`(c, field)`.
///
/// ```
/// use settings::{Checker, ConfigError};
///
/// struct Sopm { rows: u32, cols: u32, p_occ: f32 }
/// struct Mapper { min_score: f32, sopm: Sopm }
///
/// impl Sopm {
///     /// `c` is at this table (`mapper.sopm`), handed down by the parent.
///     fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
///         settings::ranges!(c, self, {
///             [rows, cols]: count(1, 64),
///             p_occ: require(self.p_occ > 0.5 && self.p_occ < 1.0, "must be in (0.5, 1)"),
///         });
///         Ok(())
///     }
/// }
///
/// impl Mapper {
///     fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
///         let c = &c.at("mapper"); // the section's own name, once
///         settings::ranges!(c, self, {
///             min_score: in_range(0.0, 1.0),
///             sopm: section,
///         });
///         Ok(())
///     }
/// }
///
/// let m = Mapper { min_score: 0.5, sopm: Sopm { rows: 8, cols: 100, p_occ: 0.7 } };
/// let e = m.validate(&Checker::new("my.toml")).unwrap_err();
/// assert_eq!(e.to_string(), "my.toml: mapper.sopm.cols = 100: must be in [1, 64]");
/// ```
#[macro_export]
macro_rules! ranges {
    // One entry at a time (so a rule's arguments never repeat with the field list).
    (@entries ($c:expr) ($s:expr) $(,)?) => {};
    (@entries ($c:expr) ($s:expr) [$($f:ident),+ $(,)?] : $rule:ident $(, $($rest:tt)*)?) => {
        $($crate::ranges!(@rule ($c) ($s) $f $rule ());)+
        $crate::ranges!(@entries ($c) ($s) $($($rest)*)?);
    };
    (@entries ($c:expr) ($s:expr) [$($f:ident),+ $(,)?] : $rule:ident $args:tt $(, $($rest:tt)*)?) => {
        $($crate::ranges!(@rule ($c) ($s) $f $rule $args);)+
        $crate::ranges!(@entries ($c) ($s) $($($rest)*)?);
    };
    (@entries ($c:expr) ($s:expr) $f:ident : $($rest:tt)*) => {
        $crate::ranges!(@entries ($c) ($s) [$f] : $($rest)*);
    };
    // The rules.
    (@rule ($c:expr) ($s:expr) $f:ident in_range ($lo:expr, $hi:expr $(,)?)) => {
        $c.in_range(&$crate::key!($c, $f), f64::from($s.$f), $lo, $hi)?
    };
    (@rule ($c:expr) ($s:expr) $f:ident count ($lo:expr, $hi:expr $(,)?)) => {
        $c.count(&$crate::key!($c, $f), $crate::Count::as_count($s.$f), $lo, $hi)?
    };
    (@rule ($c:expr) ($s:expr) $f:ident within ($lo:expr, $hi:expr $(,)?)) => {
        $c.within(&$crate::key!($c, $f), $s.$f, $lo, $hi)?
    };
    (@rule ($c:expr) ($s:expr) $f:ident positive ()) => {
        $c.positive(&$crate::key!($c, $f), f64::from($s.$f))?
    };
    (@rule ($c:expr) ($s:expr) $f:ident require ($ok:expr, $expected:expr $(,)?)) => {
        $c.require($ok, &$crate::key!($c, $f), &$s.$f, $expected)?
    };
    (@rule ($c:expr) ($s:expr) $f:ident section ()) => {
        $s.$f.validate(&$c.at(stringify!($f)))?
    };
    (@rule ($c:expr) ($s:expr) $f:ident $($other:tt)*) => {
        compile_error!(concat!(
            "ranges!: unknown rule for `", stringify!($f), "`: ", stringify!($($other)*),
            " (in_range, count, within, positive, require, section)"
        ))
    };
    ($c:expr, $s:expr, { $($entries:tt)* }) => {
        $crate::ranges!(@entries ($c) ($s) $($entries)*)
    };
}

/// The dotted key of `field` in the [`Checker`](crate::Checker) `c`'s table, from the field's
/// name: `key!(c, min_z)` at `mapper.grid` is `"mapper.grid.min_z"`. For hand-written checks
/// (loops, arrays) and for error texts that name another key.
#[macro_export]
macro_rules! key {
    ($c:expr, $f:ident) => {
        $c.key(stringify!($f))
    };
}

#[cfg(test)]
mod tests {
    use crate::{Checker, ConfigError};

    struct Grid {
        width: u32,
        height: u32,
        min_z: f32,
        max_z: f32,
    }

    impl Grid {
        fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
            crate::ranges!(c, self, {
                [width, height]: count(1, 256),
                min_z: in_range(0.0, 5.0),
                max_z: require(
                    self.max_z > self.min_z,
                    &format!("must be > {}", crate::key!(c, min_z)),
                ),
            });
            Ok(())
        }
    }

    struct Mapper {
        stride: u64,
        gain: f64,
        nice: i32,
        grid: Grid,
    }

    impl Mapper {
        fn validate(&self, c: &Checker) -> Result<(), ConfigError> {
            let c = &c.at("mapper");
            crate::ranges!(c, self, {
                stride: count(1, 64),
                gain: positive,
                nice: within(-20, 19),
                grid: section,
            });
            Ok(())
        }
    }

    fn mapper() -> Mapper {
        Mapper {
            stride: 4,
            gain: 1.5,
            nice: 0,
            grid: Grid {
                width: 100,
                height: 100,
                min_z: 0.1,
                max_z: 2.0,
            },
        }
    }

    fn error(m: &Mapper) -> String {
        m.validate(&Checker::new("t.toml")).unwrap_err().to_string()
    }

    #[test]
    fn keys_come_from_the_field_names_under_the_parents_prefix() {
        assert!(mapper().validate(&Checker::new("t.toml")).is_ok());
        let mut m = mapper();
        m.grid.height = 300;
        assert_eq!(
            error(&m),
            "t.toml: mapper.grid.height = 300: must be in [1, 256]"
        );
        m.grid.height = 10;
        m.grid.max_z = 0.05;
        assert_eq!(
            error(&m),
            "t.toml: mapper.grid.max_z = 0.05: must be > mapper.grid.min_z"
        );
        m.grid.min_z = 5.5;
        let e = m.validate(&Checker::new("t.toml")).unwrap_err();
        assert_eq!(
            e.key(),
            "mapper.grid.min_z",
            "the first rule written is reported first"
        );
        // An f32 is checked as the f64 it converts to, as `Checker::in_range` always did.
        assert_eq!(
            e.to_string(),
            "t.toml: mapper.grid.min_z = 5.5: must be in [0, 5]"
        );
    }

    #[test]
    fn each_rule_gives_the_checkers_text() {
        let mut m = mapper();
        m.stride = 0;
        assert_eq!(error(&m), "t.toml: mapper.stride = 0: must be in [1, 64]");
        m.stride = 1;
        m.gain = f64::INFINITY;
        assert_eq!(
            error(&m),
            "t.toml: mapper.gain = inf: must be a finite number > 0"
        );
        m.gain = 1.0;
        m.nice = -21;
        assert_eq!(error(&m), "t.toml: mapper.nice = -21: must be in [-20, 19]");
    }

    #[test]
    fn a_checker_at_the_root_gives_bare_keys() {
        let c = Checker::new("t.toml");
        assert_eq!(crate::key!(c, rows), "rows");
        assert_eq!(c.at("a").at("b").key("c"), "a.b.c");
        assert_eq!(c.at("a").file(), c.file());
    }
}
