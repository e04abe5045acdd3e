//! Validated numbers: the config's number types, whose `TryFrom` refuses
//! an out-of-range value with the message the user reads, and the way
//! those messages print a user's number ([`short`]).

use serde::Deserialize;

/// A finite number greater than zero.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(try_from = "f64")]
pub struct Positive(pub f32);

impl TryFrom<f64> for Positive {
    type Error = String;
    fn try_from(v: f64) -> Result<Self, String> {
        if !(v.is_finite() && v > 0.0) {
            return Err(format!(
                "must be a finite number greater than 0, got {}",
                short(v)
            ));
        }
        single(v).map(Positive)
    }
}

/// `v` (finite, nonzero) in single precision, where the stages compute:
/// a value whose f32 would be infinite, or zero or subnormal (a length of
/// 1e-300 would become a voxel of 0), is refused rather than rounded.
fn single(v: f64) -> Result<f32, String> {
    let f = v as f32;
    if f.is_finite() && f.abs() >= f32::MIN_POSITIVE {
        Ok(f)
    } else {
        Err(format!(
            "must lie within single precision, about 1.2e-38 to 3.4e38 in size, got {}",
            short(v)
        ))
    }
}

/// `v` as messages print a user's number: plainly when of moderate size
/// (`0.25`, `-5`, `1200`), in exponent form when very large or very small
/// (`1e300`, `1.5e-12`), so that `voxel_size: 1e300` is not echoed as 301
/// digits. Takes f32 or f64 and prints the shortest digits that read back
/// as the same value of that type (an f32's `0.1` stays `0.1`).
pub fn short<T>(v: T) -> String
where
    T: Copy + Into<f64> + std::fmt::Display + std::fmt::LowerExp,
{
    let x: f64 = v.into();
    let a = x.abs();
    if a.is_finite() && (a >= 1e6 || (a > 0.0 && a < 1e-4)) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Numbers as [`short`] prints them, in RON's tuple form: `(0, 1e300, 2.5)`.
pub fn short_all<T>(v: &[T]) -> String
where
    T: Copy + Into<f64> + std::fmt::Display + std::fmt::LowerExp,
{
    let parts: Vec<String> = v.iter().map(|&x| short(x)).collect();
    format!("({})", parts.join(", "))
}

/// A finite number greater than zero, kept in double precision: the scene's
/// `scale`, which multiplies file coordinates read in f64 (see
/// [`crate::scene`]), so that a file in millimetres with `scale: 0.001` and
/// the same file in metres give the same scene.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(try_from = "f64")]
pub struct Scale(pub f64);

impl TryFrom<f64> for Scale {
    type Error = String;
    fn try_from(v: f64) -> Result<Self, String> {
        if v.is_finite() && v > 0.0 {
            Ok(Scale(v))
        } else {
            Err(format!(
                "must be a finite number greater than 0, got {}",
                short(v)
            ))
        }
    }
}

/// A number in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(try_from = "f64")]
pub struct Fraction(pub f32);

impl TryFrom<f64> for Fraction {
    type Error = String;
    fn try_from(v: f64) -> Result<Self, String> {
        if (0.0..=1.0).contains(&v) {
            Ok(Fraction(v as f32))
        } else {
            Err(format!("must lie in [0, 1], got {}", short(v)))
        }
    }
}

/// A finite number of at least zero.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(try_from = "f64")]
pub struct NonNegative(pub f32);

impl TryFrom<f64> for NonNegative {
    type Error = String;
    fn try_from(v: f64) -> Result<Self, String> {
        if v.is_finite() && v >= 0.0 && v <= f32::MAX as f64 {
            Ok(NonNegative(v as f32))
        } else {
            Err(format!(
                "must be a finite number of at least 0 (and below 3e38), got {}",
                short(v)
            ))
        }
    }
}

/// A whole number in `1..=MAX`. The upper bounds keep a typo (an extra
/// zero or three) from turning into an out-of-memory crash.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(try_from = "u64")]
pub struct Count<const MAX: u32 = { u32::MAX }>(pub u32);

impl<const MAX: u32> TryFrom<u64> for Count<MAX> {
    type Error = String;
    fn try_from(v: u64) -> Result<Self, String> {
        if (1..=MAX as u64).contains(&v) {
            Ok(Count(v as u32))
        } else {
            Err(format!("must be a whole number from 1 to {MAX}, got {v}"))
        }
    }
}

/// An angle in degrees, strictly between 0 and 90.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(try_from = "f64")]
pub struct Degrees(pub f32);

impl TryFrom<f64> for Degrees {
    type Error = String;
    fn try_from(v: f64) -> Result<Self, String> {
        // Checked in single precision too: 1e-300 degrees is 0 as an f32.
        let f = v as f32;
        if v > 0.0 && v < 90.0 && f > 0.0 && f < 90.0 {
            Ok(Degrees(f))
        } else {
            Err(format!(
                "must lie strictly between 0 and 90 degrees, got {}",
                short(v)
            ))
        }
    }
}

/// A finite point in world coordinates (after `scale` and `up`). Kept in
/// f64: the stages see it relative to the scene's origin
/// ([`crate::scene::Scene::to_local`]), and rounding it to f32 first would
/// lose what that subtraction keeps far from the world origin.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(try_from = "[f64; 3]")]
pub struct Point3(pub [f64; 3]);

/// A direction: three finite numbers, not all zero, normalized on reading.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(try_from = "[f64; 3]")]
pub struct Direction(pub [f32; 3]);

/// A radiometric colour: three finite numbers of at least 0 (linear RGB).
#[derive(Debug, Clone, Copy, PartialEq, Deserialize)]
#[serde(try_from = "[f64; 3]")]
pub struct Rgb(pub [f32; 3]);

/// A whole number in `0..=MAX` (bounce counts, where 0 is meaningful).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(try_from = "u64")]
pub struct Whole<const MAX: u32>(pub u32);

impl<const MAX: u32> TryFrom<u64> for Whole<MAX> {
    type Error = String;
    fn try_from(v: u64) -> Result<Self, String> {
        if v <= MAX as u64 {
            Ok(Whole(v as u32))
        } else {
            Err(format!("must be a whole number from 0 to {MAX}, got {v}"))
        }
    }
}

/// A power of two in `MIN..=MAX` (octahedral map sides, so that every
/// pyramid level halves exactly).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(try_from = "u64")]
pub struct PowerOfTwo<const MIN: u32, const MAX: u32>(pub u32);

impl<const MIN: u32, const MAX: u32> TryFrom<u64> for PowerOfTwo<MIN, MAX> {
    type Error = String;
    fn try_from(v: u64) -> Result<Self, String> {
        if v.is_power_of_two() && (MIN as u64..=MAX as u64).contains(&v) {
            Ok(PowerOfTwo(v as u32))
        } else {
            Err(format!(
                "must be a power of two from {MIN} to {MAX}, got {v}"
            ))
        }
    }
}

impl TryFrom<[f64; 3]> for Point3 {
    type Error = String;
    fn try_from(v: [f64; 3]) -> Result<Self, String> {
        if v.iter()
            .all(|c| c.is_finite() && c.abs() <= f32::MAX as f64)
        {
            Ok(Point3(v))
        } else {
            Err(format!(
                "must be three finite numbers (below 3e38 in size), got {}",
                short_all(&v)
            ))
        }
    }
}

impl TryFrom<[f64; 3]> for Direction {
    type Error = String;
    fn try_from(v: [f64; 3]) -> Result<Self, String> {
        let len = v.iter().map(|c| c * c).sum::<f64>().sqrt();
        if v.iter().all(|c| c.is_finite()) && len > 1e-12 && len.is_finite() {
            Ok(Direction(v.map(|c| (c / len) as f32)))
        } else {
            Err(format!(
                "must be three finite numbers, not all zero, got {}",
                short_all(&v)
            ))
        }
    }
}

impl TryFrom<[f64; 3]> for Rgb {
    type Error = String;
    fn try_from(v: [f64; 3]) -> Result<Self, String> {
        if v.iter()
            .all(|c| c.is_finite() && *c >= 0.0 && *c <= f32::MAX as f64)
        {
            Ok(Rgb(v.map(|c| c as f32)))
        } else {
            Err(format!(
                "must be three finite numbers of at least 0 (and below 3e38), got {}",
                short_all(&v)
            ))
        }
    }
}
