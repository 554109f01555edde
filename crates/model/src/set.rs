//! Coefficient sets as data: which monomials of (Δu', v', r', δ) each degree of freedom regresses, which
//! acceleration derivatives are known, and optional bounds or sign constraints per term with their source.

use std::fmt;

use serde::{Deserialize, Serialize};

/// A degree of freedom: surge force X, sway force Y, yaw moment N.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Dof {
    X,
    Y,
    N,
}

impl Dof {
    pub const ALL: [Dof; 3] = [Dof::X, Dof::Y, Dof::N];

    pub fn index(self) -> usize {
        self as usize
    }

    pub fn as_str(self) -> &'static str {
        match self {
            Dof::X => "X",
            Dof::Y => "Y",
            Dof::N => "N",
        }
    }
}

impl fmt::Display for Dof {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A monomial Δu'^a v'^b r'^c δ^d, written as letters: "uvv" = Δu' v'², "d" = δ, "1" = constant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Monomial {
    pub du: u8,
    pub v: u8,
    pub r: u8,
    pub delta: u8,
}

impl Monomial {
    /// Parse the letter code; letters may come in any order ("vrd" = "dvr").
    pub fn parse(code: &str) -> Result<Monomial, String> {
        let mut m = Monomial {
            du: 0,
            v: 0,
            r: 0,
            delta: 0,
        };
        if code == "1" {
            return Ok(m);
        }
        if code.is_empty() {
            return Err("empty term (write \"1\" for a constant)".into());
        }
        for c in code.chars() {
            match c {
                'u' => m.du += 1,
                'v' => m.v += 1,
                'r' => m.r += 1,
                'd' => m.delta += 1,
                other => {
                    return Err(format!(
                        "term \"{code}\": unknown letter '{other}' (u = Δu', v, r, d = δ, or \"1\")"
                    ));
                }
            }
        }
        if m.degree() > 4 {
            return Err(format!("term \"{code}\": degree {} above 4", m.degree()));
        }
        Ok(m)
    }

    pub fn degree(&self) -> u8 {
        self.du + self.v + self.r + self.delta
    }

    /// Canonical letter code (u, v, r, d order; "1" for the constant).
    pub fn code(&self) -> String {
        if self.degree() == 0 {
            return "1".into();
        }
        let mut s = String::new();
        for (c, n) in [
            ('u', self.du),
            ('v', self.v),
            ('r', self.r),
            ('d', self.delta),
        ] {
            s.extend(std::iter::repeat_n(c, n as usize));
        }
        s
    }

    /// Coefficient name in the usual notation: X_uu, Y_vvr, N_d, Y_0.
    pub fn coefficient_name(&self, dof: Dof) -> String {
        match self.degree() {
            0 => format!("{dof}_0"),
            _ => format!("{dof}_{}", self.code()),
        }
    }

    /// Value at primed state (Δu', v', r', δ [rad]).
    #[inline]
    pub fn eval(&self, du: f64, v: f64, r: f64, delta: f64) -> f64 {
        du.powi(self.du as i32)
            * v.powi(self.v as i32)
            * r.powi(self.r as i32)
            * delta.powi(self.delta as i32)
    }

    /// [`Monomial::eval`] from powers tabulated once per state: the same value to the last
    /// bit, without four `powi` calls per term (which were a fifth of a diagnosis's time).
    #[inline]
    pub fn eval_powers(&self, p: &Powers) -> f64 {
        p.get(0, self.du) * p.get(1, self.v) * p.get(2, self.r) * p.get(3, self.delta)
    }

    /// [`Monomial::eval_powers`] and the gradient ∂/∂(Δu', v', r') at the same state: what a
    /// sensitivity replay needs of every term at every RK4 stage (`shipid_sim::dynamics::Parametric`).
    /// The value is the same to the last bit as [`Monomial::eval_powers`].
    #[inline]
    pub fn eval_with_gradient(&self, p: &Powers) -> (f64, [f64; 3]) {
        let (a, b, c, d) = (
            p.get(0, self.du),
            p.get(1, self.v),
            p.get(2, self.r),
            p.get(3, self.delta),
        );
        let lower = |variable: usize, exponent: u8| match exponent {
            0 => 0.0,
            e => f64::from(e) * p.get(variable, e - 1),
        };
        (
            a * b * c * d,
            [
                lower(0, self.du) * b * c * d,
                a * lower(1, self.v) * c * d,
                a * b * lower(2, self.r) * d,
            ],
        )
    }

    /// Parity under (v, r, δ) → (−v, −r, −δ): true when the term changes sign.
    pub fn is_odd(&self) -> bool {
        (self.v + self.r + self.delta) % 2 == 1
    }
}

/// Powers 0–3 of (Δu', v', r', δ) at one state, each as `powi` computes it (binary
/// powering: x³ = x·x², so the products below round exactly as `powi` does); higher
/// exponents fall back to `powi`.
#[derive(Debug, Clone, Copy)]
pub struct Powers {
    table: [[f64; 4]; 4],
}

impl Powers {
    pub fn new(du: f64, v: f64, r: f64, delta: f64) -> Powers {
        let row = |x: f64| {
            let x2 = x * x;
            [1.0, x, x2, x * x2]
        };
        Powers {
            table: [row(du), row(v), row(r), row(delta)],
        }
    }

    #[inline]
    fn get(&self, variable: usize, exponent: u8) -> f64 {
        match self.table[variable].get(exponent as usize) {
            Some(&p) => p,
            None => self.table[variable][1].powi(exponent as i32),
        }
    }
}

/// An acceleration derivative that a set takes as known (not regressed).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Known {
    Udot,
    Vdot,
    Rdot,
}

/// A bound or sign constraint on one coefficient (prime system), with the reason it holds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Constraint {
    pub dof: Dof,
    /// The term's letter code.
    pub term: String,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lower: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub upper: Option<f64>,
    /// "negative" (≤ 0) or "positive" (≥ 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub sign: Option<String>,
    /// Where the constraint comes from (physics, a reference, a data set).
    pub source: String,
}

/// One degree of freedom of a set file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DofSpec {
    #[serde(default)]
    pub known: Vec<Known>,
    pub terms: Vec<String>,
}

/// A coefficient set file (TOML) as written.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SetFile {
    pub name: String,
    #[serde(default)]
    pub description: String,
    pub source: String,
    #[serde(rename = "X")]
    pub x: DofSpec,
    #[serde(rename = "Y")]
    pub y: DofSpec,
    #[serde(rename = "N")]
    pub n: DofSpec,
    #[serde(default, rename = "constraint", skip_serializing_if = "Vec::is_empty")]
    pub constraints: Vec<Constraint>,
}

/// A checked coefficient set.
#[derive(Debug, Clone, PartialEq)]
pub struct CoefficientSet {
    pub name: String,
    pub description: String,
    pub source: String,
    /// Regressed monomials per DOF (X, Y, N).
    pub terms: [Vec<Monomial>; 3],
    /// Known acceleration derivatives per DOF.
    pub known: [Vec<Known>; 3],
    /// Bounds per DOF and term, same order as `terms` (−∞/+∞ when free).
    pub bounds: [Vec<(f64, f64)>; 3],
    /// The file as written (kept so a model file can embed it).
    pub file: SetFile,
}

/// A problem in a set file; `key` is the TOML key path.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("key `{key}`: {message}")]
pub struct SetError {
    pub key: String,
    pub message: String,
}

const BUILTIN: [(&str, &str); 4] = [
    ("reduced32", include_str!("../sets/reduced32.toml")),
    ("full68", include_str!("../sets/full68.toml")),
    ("full74", include_str!("../sets/full74.toml")),
    ("chen2021", include_str!("../sets/chen2021.toml")),
];

impl CoefficientSet {
    /// Names of the sets shipped with the project.
    pub fn builtin_names() -> Vec<&'static str> {
        BUILTIN.iter().map(|(n, _)| *n).collect()
    }

    /// TOML text of a shipped set.
    pub fn builtin_text(name: &str) -> Option<&'static str> {
        BUILTIN.iter().find(|(n, _)| *n == name).map(|(_, t)| *t)
    }

    /// A shipped set by name.
    pub fn builtin(name: &str) -> Option<CoefficientSet> {
        let text = Self::builtin_text(name)?;
        let file: SetFile = toml::from_str(text).ok()?;
        CoefficientSet::from_file(file).ok()
    }

    /// Check a parsed set file.
    pub fn from_file(file: SetFile) -> Result<CoefficientSet, SetError> {
        let mut terms: [Vec<Monomial>; 3] = Default::default();
        let mut known: [Vec<Known>; 3] = Default::default();
        for (d, spec) in Dof::ALL.iter().zip([&file.x, &file.y, &file.n]) {
            let i = d.index();
            if spec.terms.is_empty() {
                return Err(SetError {
                    key: format!("{d}.terms"),
                    message: "no terms".into(),
                });
            }
            for (j, code) in spec.terms.iter().enumerate() {
                let m = Monomial::parse(code).map_err(|message| SetError {
                    key: format!("{d}.terms[{j}]"),
                    message,
                })?;
                if terms[i].contains(&m) {
                    return Err(SetError {
                        key: format!("{d}.terms[{j}]"),
                        message: format!("term \"{code}\" appears twice"),
                    });
                }
                terms[i].push(m);
            }
            for k in &spec.known {
                if !known[i].contains(k) {
                    known[i].push(*k);
                }
            }
        }
        let mut bounds: [Vec<(f64, f64)>; 3] =
            std::array::from_fn(|i| vec![(f64::NEG_INFINITY, f64::INFINITY); terms[i].len()]);
        for (c_i, c) in file.constraints.iter().enumerate() {
            let key = |k: &str| format!("constraint[{c_i}].{k}");
            let m = Monomial::parse(&c.term).map_err(|message| SetError {
                key: key("term"),
                message,
            })?;
            let j = terms[c.dof.index()]
                .iter()
                .position(|t| *t == m)
                .ok_or_else(|| SetError {
                    key: key("term"),
                    message: format!("\"{}\" is not a term of {}", c.term, c.dof),
                })?;
            let (mut lo, mut hi) = (
                c.lower.unwrap_or(f64::NEG_INFINITY),
                c.upper.unwrap_or(f64::INFINITY),
            );
            match c.sign.as_deref() {
                None => {}
                Some("negative") => hi = hi.min(0.0),
                Some("positive") => lo = lo.max(0.0),
                Some(other) => {
                    return Err(SetError {
                        key: key("sign"),
                        message: format!("\"{other}\" is neither \"negative\" nor \"positive\""),
                    });
                }
            }
            if lo.is_nan() || hi.is_nan() || lo > hi {
                return Err(SetError {
                    key: key("lower"),
                    message: format!("empty range [{lo}, {hi}]"),
                });
            }
            bounds[c.dof.index()][j] = (lo, hi);
        }
        Ok(CoefficientSet {
            name: file.name.clone(),
            description: file.description.clone(),
            source: file.source.clone(),
            terms,
            known,
            bounds,
            file,
        })
    }

    /// Regressed coefficients plus known acceleration derivatives.
    pub fn coefficient_count(&self) -> usize {
        (0..3)
            .map(|i| self.terms[i].len() + self.known[i].len())
            .sum()
    }

    /// Coefficient names of one DOF, in regression order.
    pub fn names(&self, dof: Dof) -> Vec<String> {
        self.terms[dof.index()]
            .iter()
            .map(|m| m.coefficient_name(dof))
            .collect()
    }

    /// Whether any term has a finite bound.
    pub fn has_bounds(&self, dof: Dof) -> bool {
        self.bounds[dof.index()]
            .iter()
            .any(|(l, u)| l.is_finite() || u.is_finite())
    }

    pub fn knows(&self, dof: Dof, k: Known) -> bool {
        self.known[dof.index()].contains(&k)
    }
}
