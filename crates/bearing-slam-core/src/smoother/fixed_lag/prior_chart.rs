//! The chart of a marginalization prior's inverse-depth landmarks: each is
//! measured about a *pose in the window* (its anchor pose), not about the
//! fixed world point its increments use ([`Values::anchor_landmark`]).
//!
//! About a fixed anchor `a` the prior is linear in `u = [θ, ρ]` of `p − a`:
//! along the landmark's ray, which is what a landmark of unknown depth
//! needs, but not indifferent to a translation of the whole map, which the
//! bearings and odometry it replaces are (a shift `t` costs a term of order
//! `|t|²/d²`, `d` the distance from `a`). On MRCLAM Dataset 6 robot 1 that
//! term made the window rotate instead of shifting (docs/results/estimators.md,
//! "Robot 1's 1.40×"). About a pose `x_a` of the window, `u = u(p − x_a)`
//! is still linear along the ray from the anchor and is unchanged when the
//! map and the poses shift together.
//!
//! A landmark keeps its anchor pose while that pose stays in the window.
//! When the anchor pose is the one being marginalized (or the landmark
//! enters the prior for the first time) it is re-anchored, *before* the
//! Schur complement, to a pose that stays ([`PriorAnchor`]): the old prior
//! is linearized, with the other factors, in the solver's increments at the
//! linearization point, and the complement is then expressed in the new
//! chart by the change of variables `δ = T z` (`change_of_variables`),
//! exact to first order there.

use super::super::anchor_links::{AnchorLink, right_multiply};
use super::super::factors::Factor;
use super::super::graph::FactorGraph;
use super::super::values::{Key, Values, inverse_depth_chart_jacobian};
use crate::error::{Result, SlamError};
use nalgebra::{DMatrix, Matrix2, Vector2};
use std::collections::{BTreeMap, BTreeSet};

/// Which pose of the window a marginalization prior's inverse-depth
/// landmark is (re-)anchored at when it needs a new anchor pose
/// ([`super::FixedLagConfig::prior_anchor`]). A landmark keeps its anchor
/// pose while that pose stays in the window, whatever the policy.
///
/// Measured (robot 1 of MRCLAM Dataset 6, default keyframe window, ATE m;
/// batch 0.174, [`PriorAnchor::Fixed`] 0.244): newest observer 0.159,
/// oldest observer 0.162, newest 0.157, oldest 0.168. The short windows of
/// `tests/integration/smoother_keyframes.rs` tell them apart: anchored at
/// the oldest pose (the oldest observer there) a 10-keyframe window whose
/// scans observe through odometry offsets ends closer to the batch than
/// the one keeping every scan's pose, which that file checks the other way
/// round; the newest (observer) keeps every test there. On the held-out
/// Datasets 2 and 4 (SE(2)-aligned landmark RMSE, ten robots) every policy
/// is mixed against the fixed anchors (sum 0.926 m): newest observer 0.965,
/// oldest observer 0.935, newest 0.990, oldest 0.940; Dataset 2 robot 4 is
/// worse under all four (0.216 → 0.224–0.240 m, the batch 0.183 m).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum PriorAnchor {
    /// The fixed world anchor of the landmark's own chart (the prior is
    /// not indifferent to a shift of the map).
    Fixed,
    /// The oldest pose staying in the window that observes the landmark;
    /// the oldest staying pose when none does.
    OldestObserver,
    /// The newest pose staying in the window that observes the landmark;
    /// the newest staying pose when none does.
    #[default]
    NewestObserver,
    /// The oldest pose staying in the window.
    Oldest,
    /// The newest pose staying in the window.
    Newest,
}

crate::named_enum!(PriorAnchor, "prior anchor", [
    Fixed => "fixed",
    OldestObserver => "oldest-observer",
    NewestObserver => "newest-observer",
    Oldest => "oldest",
    Newest => "newest",
]);

/// The anchor pose of every inverse-depth landmark among `rest` (the new
/// prior's variables): the one it had in the old prior (in `taken`) if that
/// pose is in `staying` (the window's poses that do not leave in this
/// update, oldest first), else one chosen by `policy`. `graph` holds the
/// factors left in the window (to find a landmark's observers); `point`
/// the linearization point. A landmark whose every candidate lies within
/// 1 mm of it keeps its fixed chart.
pub(crate) fn choose_anchors(
    graph: &FactorGraph,
    taken: &[Factor],
    point: &Values,
    rest: &BTreeSet<Key>,
    staying: &[u64],
    policy: PriorAnchor,
) -> Result<BTreeMap<u64, u64>> {
    let mut anchors = BTreeMap::new();
    if policy == PriorAnchor::Fixed || staying.is_empty() {
        return Ok(anchors);
    }
    let position: BTreeMap<u64, usize> = staying.iter().enumerate().map(|(i, p)| (*p, i)).collect();
    let mut old = BTreeMap::new();
    for f in taken {
        if let Factor::Linear(l) = f {
            for (k, a) in l.keys().iter().zip(l.anchors()) {
                if let (Key::Landmark(id), Some(j)) = (k, a)
                    && let Key::Pose(pose) = l.keys()[*j]
                {
                    old.insert(*id, pose);
                }
            }
        }
    }
    // Observers in the window, by landmark: (oldest, newest) position.
    let mut observers: Option<BTreeMap<u64, (usize, usize)>> = None;
    for key in rest {
        let Key::Landmark(id) = *key else { continue };
        if point.landmark_anchor(id).is_none() {
            continue;
        }
        let p = point.landmark(id)?;
        let usable = |pose: u64| -> Result<bool> {
            let x = point.pose(pose)?;
            Ok((p - x.fixed_rows::<2>(0)).norm() >= 1e-3)
        };
        if let Some(pose) = old.get(&id)
            && position.contains_key(pose)
            && usable(*pose)?
        {
            anchors.insert(id, *pose);
            continue;
        }
        let seen = match policy {
            PriorAnchor::OldestObserver | PriorAnchor::NewestObserver => observers
                .get_or_insert_with(|| observers_in(graph, &position))
                .get(&id)
                .copied(),
            _ => None,
        };
        let first = match (policy, seen) {
            (PriorAnchor::OldestObserver, Some((oldest, _))) => oldest,
            (PriorAnchor::NewestObserver, Some((_, newest))) => newest,
            (PriorAnchor::OldestObserver | PriorAnchor::Oldest, _) => 0,
            _ => staying.len() - 1,
        };
        // The chosen pose, else the nearest usable one in the window.
        let order = (0..staying.len()).map(|i| {
            let d = i as isize - first as isize;
            (d.unsigned_abs(), i)
        });
        let mut order: Vec<_> = order.collect();
        order.sort_unstable();
        for (_, i) in order {
            if usable(staying[i])? {
                anchors.insert(id, staying[i]);
                break;
            }
        }
    }
    Ok(anchors)
}

/// The oldest and newest position in the window of the poses observing
/// each landmark (measurement factors of `graph`).
fn observers_in(
    graph: &FactorGraph,
    position: &BTreeMap<u64, usize>,
) -> BTreeMap<u64, (usize, usize)> {
    let mut seen: BTreeMap<u64, (usize, usize)> = BTreeMap::new();
    for f in graph.factors().iter().filter(|f| f.is_measurement()) {
        let keys = f.keys();
        let (Some(Key::Pose(pose)), Some(Key::Landmark(id))) = (keys.first(), keys.get(1)) else {
            continue;
        };
        let Some(&i) = position.get(pose) else {
            continue;
        };
        seen.entry(*id)
            .and_modify(|(lo, hi)| {
                *lo = (*lo).min(i);
                *hi = (*hi).max(i);
            })
            .or_insert((i, i));
    }
    seen
}

/// The change of variables from the prior's chart `z` to the solver's
/// increments `δ = T z` at a linearization point (`change_of_variables`):
/// the identity but for a pose-anchored landmark `l` with anchor `a`,
/// `p = x_a + c_a(u)` and `p = c_l(δ_l)` giving
/// `δ_l = C_l⁻¹ (C_a u + [I 0] δ_a)` (`C_l`, `C_a` the two charts'
/// `∂p/∂[θ, ρ]`): blocks `T_ll = C_l⁻¹ C_a` and `T_la = C_l⁻¹`, so a prior
/// `R δ + r₀` formed in the solver's increments becomes `(R T) z + r₀`
/// by column operations ([`right_multiply`]).
#[derive(Debug, Default)]
pub(crate) struct ChangeOfVariables {
    links: Vec<AnchorLink>,
}

impl ChangeOfVariables {
    /// `R T`.
    pub(crate) fn right_apply(&self, mut r: DMatrix<f64>) -> DMatrix<f64> {
        right_multiply(&mut r, &self.links);
        r
    }

    /// `T` itself, dense (for checking `right_apply`).
    #[cfg(test)]
    fn dense(&self, n: usize) -> DMatrix<f64> {
        let mut t = DMatrix::<f64>::identity(n, n);
        for link in &self.links {
            t.view_mut((link.landmark, link.landmark), (2, 2))
                .copy_from(&link.on_landmark);
            t.view_mut((link.landmark, link.anchor), (2, 2))
                .copy_from(&link.on_anchor);
        }
        t
    }
}

/// The change of variables ([`ChangeOfVariables`]) from the prior's chart
/// to the solver's increments at `point`, over `keys` (the prior's
/// variables in order), and the anchor index (in `keys`) of each key.
pub(crate) fn change_of_variables(
    keys: &[Key],
    anchors: &BTreeMap<u64, u64>,
    point: &Values,
) -> Result<(ChangeOfVariables, Vec<Option<usize>>)> {
    let mut offsets = Vec::with_capacity(keys.len());
    let mut index = BTreeMap::new();
    let mut n = 0;
    for (i, k) in keys.iter().enumerate() {
        offsets.push(n);
        index.insert(*k, i);
        n += k.dim();
    }
    let mut change = ChangeOfVariables::default();
    let mut slots = vec![None; keys.len()];
    for (id, pose) in anchors {
        let (Some(&i), Some(&j)) = (index.get(&Key::Landmark(*id)), index.get(&Key::Pose(*pose)))
        else {
            return Err(SlamError::Degenerate(
                "a prior landmark's anchor pose must be a variable of the prior",
            ));
        };
        let p = point.landmark(*id)?;
        let a = point.pose(*pose)?;
        let c_a = inverse_depth_chart_jacobian(&Vector2::new(a.x, a.y), &p)?;
        let c_l_inv = match point.landmark_chart_jacobian(*id)? {
            Some(c) => c.try_inverse().ok_or(SlamError::Degenerate(
                "a landmark's inverse-depth chart is singular at its point",
            ))?,
            None => Matrix2::identity(),
        };
        change.links.push(AnchorLink {
            landmark: offsets[i],
            anchor: offsets[j],
            on_landmark: c_l_inv * c_a,
            on_anchor: c_l_inv,
        });
        slots[i] = Some(j);
    }
    Ok((change, slots))
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Vector3;

    /// `right_apply` is the product with the dense `T`, for a landmark in
    /// its point chart and one in inverse depth, both anchored at one pose.
    #[test]
    fn the_column_operations_are_the_product_with_t() -> Result<()> {
        let keys = [
            Key::Pose(1),
            Key::Pose(2),
            Key::Landmark(4),
            Key::Landmark(6),
        ];
        let mut point = Values::new();
        point.insert_pose(1, Vector3::new(0.0, 0.0, 0.1))?;
        point.insert_pose(2, Vector3::new(1.0, 0.5, 0.3))?;
        point.insert_landmark(4, Vector2::new(4.0, 2.0))?;
        point.insert_landmark(6, Vector2::new(-3.0, 5.0))?;
        point.anchor_landmark(6, Vector2::new(0.5, 0.5))?;
        let anchors = BTreeMap::from([(4, 2), (6, 2)]);
        let (change, slots) = change_of_variables(&keys, &anchors, &point)?;
        assert_eq!(slots, vec![None, None, Some(1), Some(1)]);
        let r = DMatrix::from_fn(9, 10, |i, j| ((i * 5 + j * 3) % 7) as f64 - 3.0);
        let expected = &r * change.dense(10);
        let got = change.right_apply(r.clone());
        assert!((got - &expected).amax() < 1e-12 * expected.amax());
        assert!((expected - r).amax() > 1e-3);
        Ok(())
    }
}
