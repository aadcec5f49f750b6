//! One spelling per choice: the closed sets of names that configurations,
//! the Python package and the command lines share (initializers, covariance
//! updates, odometry models, evaluation methods).
//!
//! Each such concept is one Rust enum implementing [`Named`] through
//! [`named_enum!`](crate::named_enum): its variants' names, their order
//! ([`Named::ALL`]), parsing ([`std::str::FromStr`]) and printing
//! ([`std::fmt::Display`]) are written once, here in Rust. Python reads them
//! from the extension module instead of restating them.

/// A name that is not one of a [`Named`] enum's.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown {what} {name:?}: expected one of {known}")]
pub struct UnknownName {
    /// What the names name (`"initializer"`).
    pub what: &'static str,
    /// The name given.
    pub name: String,
    /// The known names, comma-separated, in [`Named::ALL`] order.
    pub known: String,
}

/// An enum whose variants each have one name.
pub trait Named: Copy + Eq + 'static {
    /// What the names name, for messages (`"initializer"`).
    const WHAT: &'static str;
    /// Every variant, in the order tables and help texts list them.
    const ALL: &'static [Self];

    /// The variant's name.
    fn name(self) -> &'static str;

    /// Every name, in [`Self::ALL`] order.
    #[must_use]
    fn names() -> Vec<&'static str> {
        Self::ALL.iter().map(|v| v.name()).collect()
    }

    /// The variant called `name`.
    ///
    /// # Errors
    /// [`UnknownName`] listing the known names.
    fn from_name(name: &str) -> Result<Self, UnknownName> {
        Self::ALL
            .iter()
            .copied()
            .find(|v| v.name() == name)
            .ok_or_else(|| UnknownName {
                what: Self::WHAT,
                name: name.to_owned(),
                known: Self::names().join(", "),
            })
    }
}

/// Implements [`Named`], [`std::str::FromStr`] and [`std::fmt::Display`]
/// for a fieldless enum from one table of `Variant => "name"` pairs (the
/// order is [`Named::ALL`]'s).
#[macro_export]
macro_rules! named_enum {
    ($ty:ty, $what:literal, [$($variant:ident => $name:literal),+ $(,)?]) => {
        impl $crate::names::Named for $ty {
            const WHAT: &'static str = $what;
            const ALL: &'static [Self] = &[$(<$ty>::$variant),+];

            fn name(self) -> &'static str {
                match self {
                    $(<$ty>::$variant => $name),+
                }
            }
        }

        impl ::std::str::FromStr for $ty {
            type Err = $crate::names::UnknownName;

            fn from_str(s: &str) -> ::std::result::Result<Self, Self::Err> {
                <$ty as $crate::names::Named>::from_name(s)
            }
        }

        impl ::std::fmt::Display for $ty {
            fn fmt(&self, f: &mut ::std::fmt::Formatter<'_>) -> ::std::fmt::Result {
                f.write_str($crate::names::Named::name(*self))
            }
        }
    };
}

#[cfg(test)]
mod tests {
    use super::Named;

    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    enum Colour {
        Red,
        DarkBlue,
    }
    crate::named_enum!(Colour, "colour", [Red => "red", DarkBlue => "dark-blue"]);

    #[test]
    fn names_round_trip_and_unknown_names_list_the_known_ones() {
        for c in Colour::ALL {
            assert_eq!(c.name().parse::<Colour>(), Ok(*c));
            assert_eq!(c.to_string(), c.name());
        }
        assert_eq!(Colour::names(), ["red", "dark-blue"]);
        let Err(e) = "blue".parse::<Colour>() else {
            panic!("an unknown name parsed");
        };
        assert_eq!(
            e.to_string(),
            "unknown colour \"blue\": expected one of red, dark-blue"
        );
    }
}
