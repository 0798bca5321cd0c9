//! Slack walls: the slack faces a Newton step runs into, in the next step's model.
//!
//! On a mold filled well below its top, the fabric above the liquid hangs slack or wrinkled and
//! carries the liquid's weight to the clamps along wrinkled tension paths; Newton then creeps
//! for thousands of iterations (SIMULATION_LOG, 2026-12-06 to 12-07). Traced on the torus
//! filled to 0.1 m of 0.5 m (2026-12-07, twenty-ninth session, iterations 200–221), every full
//! step the line search rejected rose in energy through the faces that were slack at the iterate
//! and wrinkled at the trial point: their excess over the quadratic model was the whole rise,
//! the taut and wrinkled faces and the pressure followed the model to 10⁻¹¹ J. A slack face has no
//! energy and so no Hessian: the step model does not see the stiffness the face takes on as soon
//! as its largest principal Green strain e1 turns positive (the tension-field model's wrinkled
//! state, `W = ½ Y e1²` per unit rest area), and the damping alone had to keep the step short of
//! it.
//!
//! A wall is that face's energy in the step model, `½ A Y ⟨e1 + a·d⟩₊²` (A its rest area, `a`
//! the gradient of e1 over the face's free dofs, d the step): one-sided, it lets the face go
//! slacker or stretch up to its rest length freely and stiffens it past that. For a face in the
//! model the step solves `(H + μM + A Y a aᵀ) d = −g − A Y e1 a`: the term is the positive
//! part's quadratic, two-sided once the face is in the model (hence [`WALL_GAP`]). The set of
//! faces in the model is the one the previous step predicted to cross (`e1 + a·d > 0` along it, with its own set),
//! lagged by one iteration, so that a step costs one factorization as before. Solving for the
//! consistent set each step (semismooth Newton on the piecewise-quadratic model) took 2.7–4.1
//! factorizations per iteration for 20–36% fewer iterations: slower (torus 2994 → 1915–2273
//! iterations and 5233–6297 factorizations, bunny 2449 → 1954 and 8003). The energy and the
//! gradient stay exact: only the step changes, and the line search still decides.
//!
//! The walls come into the model after [`crate::newton::CREEP_AFTER`] iterations, those of a
//! creeping solve (the full fills in the README's tables all converge within 200): from the
//! start, the torus filled to 0.1 m took 2713 iterations, against 1543 with the walls after 200
//! and 2994 without them. Only faces within [`WALL_GAP`] of their wall enter the model (the
//! term is two-sided, see there): torus 1543 → 1436.
//! Over twelve partial fills at 0.5 m (torus, bunny, fertility, spot filled to 0.1, 0.25 and
//! 0.35 m): 15844 → 10268 iterations, 49% fewer filled to 0.1 m (SIMULATION_LOG, 2026-12-07).
//! Materials without a slack state ([`crate::material::Material::slack_wall_stiffness`] `None`)
//! have none, and the coarse start's levels ([`crate::coarse`]) have none. The fine solve from
//! the coarse start has them since the thirty-seventh session (2026-12-08; before, it had none,
//! as the levels): kitten filled to a fifth took 1316 fine iterations with them in its fine
//! solve only, against 3082 without (494 against 1099 s the same day; the thirtieth session,
//! with them also on the levels, had stopped it unconverged after 3098), but bunny_hr more:
//! 8276, against 5980 without (1418 against 911 s the same day). On six meshes of 12k–25k faces
//! simplified from spot, kitten and bunny_hr, filled to 0.1, 0.2 and 0.3 m: 598 s from the
//! target, 1005 s from the coarse start without them, 639 s with them (SIMULATION_LOG,
//! thirty-seventh session).

use clothcast_mesh::sparse::SymmetricPattern;

/// How far from its wall a flagged slack face may be and still enter the step model: its
/// largest principal Green strain above `−WALL_GAP`.
///
/// The wall's term is two-sided, `½ A Y (e1 + a·d)²`: a face the step leaves short of its wall
/// (`e1 + a·d < 0` at the solution) is pulled toward it, a force the fabric does not have. The
/// set lags one iteration, and after a shortened step the damping is four times higher, so the
/// next step often stops short of faces the last one crossed. Traced on kitten filled to 0.1 m
/// of 0.5 m (2026-12-07, thirtieth session, fine iterations 200–1167), two of three walls
/// pulled, from gaps of up to 5·10⁻³, and the solve fell into a cycle of period two: a step at
/// the lower damping ran into 140–280 faces and was cut, mostly to 1.6–6·10⁻²; the next, at
/// four times the damping and with 49–123 of them as walls, was taken whole; the damping went
/// back down, and again. The damping stayed at 1.9–7.6·10⁻⁴ and the relative residual's median
/// at 2.5–2.9·10⁻⁴ over iterations 400–1000. A face within 10⁻⁴ of its wall is pulled at most
/// that far (SIMULATION_LOG, thirtieth session).
pub const WALL_GAP: f64 = 1e-4;

/// A slack face as a wall of Newton's step model ([`crate::system::System::slack_walls`]).
#[derive(Clone, Copy, Debug)]
pub struct Wall {
    /// The face (its index).
    pub face: u32,
    /// Its largest principal Green strain (≤ 0: slack).
    pub e1: f64,
    /// `A · Y` (N·m): its rest area times the stiffness it takes on in tension.
    pub stiffness: f64,
    /// Its corners' free dofs, corner-major (`u32::MAX`: constrained).
    pub dofs: [u32; 9],
    /// ∂e1/∂dof for each of them.
    pub coef: [f64; 9],
}

impl Wall {
    /// Whether the face is near enough its wall to enter the step model ([`WALL_GAP`]).
    pub fn within_gap(&self) -> bool {
        self.e1 > -WALL_GAP
    }

    /// e1 linearized along the step `d` (on free dofs).
    pub fn strain_along(&self, d: &[f64]) -> f64 {
        self.e1
            + self
                .dofs
                .iter()
                .zip(&self.coef)
                .filter(|(i, _)| **i != u32::MAX)
                .map(|(i, c)| c * d[*i as usize])
                .sum::<f64>()
    }

    /// Adds its term of the step model, `½ A Y (e1 + a·d)²`, to the step's system: `A Y a aᵀ`
    /// to the matrix values (lower triangle of `pattern`) and `−A Y e1 a` to the right-hand
    /// side.
    pub fn add_to(&self, pattern: &SymmetricPattern, vals: &mut [f64], rhs: &mut [f64]) {
        for i in 0..9 {
            let di = self.dofs[i];
            if di == u32::MAX {
                continue;
            }
            rhs[di as usize] -= self.stiffness * self.e1 * self.coef[i];
            // Each unordered pair once: the pattern stores one triangle.
            for j in 0..=i {
                let dj = self.dofs[j];
                if dj == u32::MAX {
                    continue;
                }
                if let Some(s) = pattern.find(di as usize, dj as usize) {
                    vals[s] += self.stiffness * self.coef[i] * self.coef[j];
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wall_adds_its_rank_one_term_and_offset() {
        // Dofs 0..4 of a 4×4 dense pattern; corner 1 constrained, corner 2 with one free dof.
        let pattern = SymmetricPattern::from_entries(4, (0..4).flat_map(|i| (0..=i).map(move |j| (i, j))));
        let w = Wall {
            face: 0,
            e1: -0.01,
            stiffness: 2.0,
            dofs: [0, 1, 2, u32::MAX, u32::MAX, u32::MAX, 3, u32::MAX, u32::MAX],
            coef: [0.5, -1.0, 0.25, 9.0, 9.0, 9.0, 2.0, 9.0, 9.0],
        };
        let mut vals = vec![0.0; pattern.nnz()];
        let mut rhs = vec![1.0; 4];
        w.add_to(&pattern, &mut vals, &mut rhs);
        let a = [0.5, -1.0, 0.25, 2.0];
        for i in 0..4 {
            assert!((rhs[i] - (1.0 + 2.0 * 0.01 * a[i])).abs() < 1e-15);
            for j in 0..=i {
                assert!((vals[pattern.slot(i, j)] - 2.0 * a[i] * a[j]).abs() < 1e-15, "({i}, {j})");
            }
        }
        assert!(!w.within_gap(), "a gap of 10⁻² is beyond WALL_GAP");
        assert!(Wall { e1: -0.5 * WALL_GAP, ..w }.within_gap());
        let d = [0.1, 0.2, -0.4, 0.05];
        let lin = -0.01 + a.iter().zip(&d).map(|(x, y)| x * y).sum::<f64>();
        assert!((w.strain_along(&d) - lin).abs() < 1e-15);
    }
}
