//! Multiple importance sampling heuristics (Veach 1997, ch. 9).

/// Power heuristic with β = 2 for one sample from each strategy:
/// w_a = p_a² / (p_a² + p_b²); in the multi-sample form (Veach 1997,
/// eq. 9.13) pass each density times its strategy's sample fraction.
/// Returns 0 when both densities vanish or p_a is NaN, and 1 when p_a² is
/// infinite (its limit), where Mitsuba's `mis_weight` returns 0.
#[inline]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let (a, b) = (pdf_a * pdf_a, pdf_b * pdf_b);
    if a + b > 0.0 && a.is_finite() {
        a / (a + b)
    } else if a.is_infinite() {
        1.0
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn weights_sum_to_one() {
        for (a, b) in [(1.0, 2.0), (0.5, 0.0), (3.0, 3.0)] {
            assert!((power_heuristic(a, b) + power_heuristic(b, a) - 1.0).abs() < 1e-6);
        }
        assert_eq!(power_heuristic(0.0, 0.0), 0.0);
    }
}
