//! Built-in laws: the condition sets of the examples in the motion-design article
//! (Bewegungsdesign nach Maß).

use super::condition::{Condition, LawError};

/// A built-in law. Names (for `--preset` and the program's `PRESET=`) in [`Preset::NAMES`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Preset {
    /// "Polynom 5. Ordnung B-B" used rest to rest: the six R-R conditions.
    Rr5,
    /// R-R plus f‴(0) = f‴(1) = 0: continuous jerk (Bewegungsdesign nach Maß, "Polynom 7.
    /// Ordnung").
    Rr7,
    /// R-R plus f‴ = 0 at 0, 1 and f‴ = f⁗ = 0 at 0.2, 0.8: flattened acceleration
    /// (Bewegungsdesign nach Maß, "Polynom 11. Ordnung R-R", Bild 4).
    Rr11,
    /// R-R plus f‴(0) = f‴(1) = 0, f‴ … f⁽⁸⁾ = 0 at 0.25 and f‴ … f⁽⁶⁾ = 0 at 0.82: unequal
    /// flats in acceleration and deceleration (Bewegungsdesign nach Maß). 18 conditions →
    /// degree 17.
    Asymmetric,
    /// R-R plus f‴(0) = f‴(1) = 0, f‴ = f⁗ = 0 at 0.14 and 0.86, f″ = f‴ = f⁗ = f⁽⁵⁾ = 0 at
    /// 0.5: an approximate constant-velocity stretch (Bewegungsdesign nach Maß, Bild 6). 16
    /// conditions → degree 15.
    ConstantVelocity,
    /// The article's worked example with nine conditions (degree 8), taken literally:
    /// f(0)=0, f(1)=1, f′(0)=0, f′(1)=0, f″(0)=0, f‴(0)=0, f‴(1)=0, f⁗(1)=0, f(0.4)=0.2.
    /// Not rest to rest (f″(1) is free), so it cannot run as a [`super::LawMove`].
    Degree8,
    /// Inflection-point shift without jerk jumps (Bewegungsdesign nach Maß: "die
    /// Interpolationsbedingung f(λ) = λ mit dem Wendepunktsparameter λ"). The article does not
    /// say which law it extends; this one extends the 7th-order R-R law, because the point of
    /// the shift is to keep the jerk continuous, which the quintic does not. 9 conditions →
    /// degree 8; λ ∈ (0, 1), and λ = ½ gives back the 7th-order law (its f(½) = ½ already).
    Inflection(f64),
}

/// The six conditions every rest-to-rest law has (Bewegungsdesign nach Maß: "Bei
/// Rast-in-Rast-Übergängen (R-R) werden immer … gesetzt").
pub(super) const REST_TO_REST: [Condition; 6] = [
    Condition::new(0, 0.0, 0.0),
    Condition::new(0, 1.0, 1.0),
    Condition::new(1, 0.0, 0.0),
    Condition::new(1, 1.0, 0.0),
    Condition::new(2, 0.0, 0.0),
    Condition::new(2, 1.0, 0.0),
];

/// f‴(0) = f‴(1) = 0: the jerk ends (Bewegungsdesign nach Maß, continuous jerk at the rests).
const JERK_ENDS: [Condition; 2] = [Condition::new(3, 0.0, 0.0), Condition::new(3, 1.0, 0.0)];

impl Preset {
    /// Accepted names; `inflection:λ` takes the parameter after the colon.
    pub const NAMES: [&'static str; 7] =
        ["rr5", "rr7", "rr11", "asymmetric", "constant-velocity", "degree8", "inflection:LAMBDA"];

    /// Parses a preset name (case-insensitive), e.g. `rr7` or `inflection:0.4`.
    pub fn parse(text: &str) -> Result<Self, LawError> {
        let lower = text.trim().to_ascii_lowercase();
        let (name, param) = match lower.split_once(':') {
            Some((n, p)) => (n, Some(p)),
            None => (lower.as_str(), None),
        };
        let preset = match name {
            "rr5" | "quintic" => Preset::Rr5,
            "rr7" => Preset::Rr7,
            "rr11" => Preset::Rr11,
            "asymmetric" => Preset::Asymmetric,
            "constant-velocity" => Preset::ConstantVelocity,
            "degree8" => Preset::Degree8,
            "inflection" => return Self::inflection(text, param),
            _ => return Err(LawError::UnknownPreset { name: text.to_string(), known: Self::NAMES.join(", ") }),
        };
        match param {
            None => Ok(preset),
            Some(_) => Err(LawError::PresetParameter { name: text.to_string(), why: "takes no parameter".into() }),
        }
    }

    fn inflection(text: &str, param: Option<&str>) -> Result<Self, LawError> {
        let bad = |why: &str| LawError::PresetParameter { name: text.to_string(), why: why.to_string() };
        let p = param.ok_or_else(|| bad("needs the inflection point λ, e.g. inflection:0.4"))?;
        let lambda: f64 = p.trim().parse().map_err(|_| bad(&format!("λ '{p}' is not a number")))?;
        if !(lambda > 0.0 && lambda < 1.0) {
            return Err(bad(&format!("λ must lie strictly between 0 and 1, got {lambda}")));
        }
        Ok(Preset::Inflection(lambda))
    }

    /// The canonical name, as [`Preset::parse`] accepts it.
    pub fn name(&self) -> String {
        match self {
            Preset::Rr5 => "rr5".into(),
            Preset::Rr7 => "rr7".into(),
            Preset::Rr11 => "rr11".into(),
            Preset::Asymmetric => "asymmetric".into(),
            Preset::ConstantVelocity => "constant-velocity".into(),
            Preset::Degree8 => "degree8".into(),
            Preset::Inflection(l) => format!("inflection:{l}"),
        }
    }

    /// All presets, with λ = 0.4 for the inflection shift (for tests and listings).
    pub fn all() -> [Preset; 7] {
        [
            Preset::Rr5,
            Preset::Rr7,
            Preset::Rr11,
            Preset::Asymmetric,
            Preset::ConstantVelocity,
            Preset::Degree8,
            Preset::Inflection(0.4),
        ]
    }

    pub fn conditions(&self) -> Vec<Condition> {
        let zero = |order: u32, z: f64| Condition::new(order, z, 0.0);
        let mut c: Vec<Condition> = Vec::new();
        match *self {
            Preset::Degree8 => {
                // Bewegungsdesign nach Maß, the nine numbered conditions, in the article's order
                return vec![
                    Condition::new(0, 0.0, 0.0),
                    Condition::new(0, 1.0, 1.0),
                    zero(1, 0.0),
                    zero(1, 1.0),
                    zero(2, 0.0),
                    zero(3, 0.0),
                    zero(3, 1.0),
                    zero(4, 1.0),
                    Condition::new(0, 0.4, 0.2),
                ];
            }
            Preset::Rr5 => c.extend(REST_TO_REST),
            Preset::Rr7 => c.extend(REST_TO_REST.iter().chain(&JERK_ENDS)),
            Preset::Rr11 => {
                c.extend(REST_TO_REST.iter().chain(&JERK_ENDS));
                c.extend([zero(3, 0.2), zero(4, 0.2), zero(3, 0.8), zero(4, 0.8)]);
            }
            Preset::Asymmetric => {
                c.extend(REST_TO_REST.iter().chain(&JERK_ENDS));
                c.extend((3..=8).map(|i| zero(i, 0.25)));
                c.extend((3..=6).map(|i| zero(i, 0.82)));
            }
            Preset::ConstantVelocity => {
                c.extend(REST_TO_REST.iter().chain(&JERK_ENDS));
                c.extend([zero(3, 0.14), zero(4, 0.14), zero(3, 0.86), zero(4, 0.86)]);
                c.extend((2..=5).map(|i| zero(i, 0.5)));
            }
            Preset::Inflection(lambda) => {
                c.extend(REST_TO_REST.iter().chain(&JERK_ENDS));
                c.push(Condition::new(0, lambda, lambda));
            }
        }
        c
    }
}
