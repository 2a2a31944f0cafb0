//! The acceptance rule: whether a candidate's replicate runs in one scene
//! reproduce the scene's target band. One rule, so the adaptive stage stops
//! on exactly what verification will judge.
//!
//! Today's rule (he2019's verification and the adaptive stage): at least
//! [`MIN_MEASURED`] seeds measured the response and their mean lies in the
//! band [lo, hi] = target × (1 ∓ tolerance). It is written into the
//! acceptance record (`verify/acceptance.json`) before the first
//! verification run.

/// Fewest measured seeds a candidate needs to pass a scene (a mean with an
/// interval).
pub const MIN_MEASURED: usize = 3;

/// True when `measured` seeds with mean `mean` (units of the band; `None`
/// when nothing was measured) pass a scene whose band is `band` = (lo, hi).
pub fn passes(measured: usize, mean: Option<f64>, band: (f64, f64)) -> bool {
    measured >= MIN_MEASURED && mean.is_some_and(|m| m >= band.0 && m <= band.1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn needs_enough_seeds_and_a_mean_inside_the_band() {
        let band = (45.41, 50.19);
        assert!(passes(3, Some(48.0), band));
        assert!(passes(5, Some(45.41), band));
        assert!(!passes(2, Some(48.0), band));
        assert!(!passes(5, Some(50.2), band));
        assert!(!passes(5, None, band));
    }
}
