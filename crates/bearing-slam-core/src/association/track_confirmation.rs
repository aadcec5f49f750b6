//! When a track of [`super`] may enter the map: the confirmation rules of
//! [`TrackSet::confirmed`] (enough sightings in enough of their scans, or
//! appearance evidence past Wald's bound; a consistent point; no better
//! supported competitor) and the opt-in stricter ones; and the tracks
//! without a point that only the far rule may bring in
//! ([`TrackSet::ready_without_point`]).

use super::{MAX_SIGHTINGS, Track, TrackSet, relative_variances, same_point};
use crate::geometry::wrap_angle;

impl TrackSet {
    /// Tracks ready for the map: seen at least `min_sightings` times in
    /// enough of their scans, with a consistent point, and not contested
    /// by another consistent track that explains most of the same bearings
    /// with a different point. Ascending ids. With descriptors, a track
    /// whose appearance evidence passes Wald's bound `ln(1/(1 − p))`
    /// (`p` = `track_gate_probability`: the probability of confirming a
    /// track of sightings that are not one landmark's is at most `1 − p`)
    /// needs only two sightings instead of `min_sightings`: the sightings
    /// are then shown to be one thing by their looks, which is what the
    /// count stands in for without them.
    #[must_use]
    pub fn confirmed(&self) -> Vec<u64> {
        self.tracks
            .iter()
            .filter(|t| {
                let timed = self.config.track_max_gap_s.is_some();
                let looks_one = t.hits >= 2 && t.appearance_score >= self.score_threshold;
                (t.hits >= self.config.min_sightings || looks_one)
                    && (timed
                        || t.hits as f64 >= self.config.min_hit_ratio * t.judged_scans(self.scan))
                    && (t.point.is_some() || looks_one)
                    && t.last().key.0 == self.scan
            })
            .filter(|t| {
                !self.tracks.iter().any(|o| {
                    o.id != t.id
                        && o.point.is_some()
                        && 2 * o.shares_with(t) > t.sightings.len()
                        && !same_point(o, t, self.gate)
                })
            })
            .filter(|t| self.ends_fit_point(t))
            .filter(|t| !self.config.confirm_constrained_depth || self.depth_constrained(t))
            .filter(|t| parallax_views(t, self.view_separation) >= self.config.min_parallax_views)
            .filter(|t| !self.config.confirm_unambiguous || !self.outranked(t))
            .filter(|t| !self.config.confirm_track_score || t.score >= self.score_threshold)
            .map(|t| t.id)
            .collect()
    }

    /// Tracks seen as often as [`Self::confirmed`] asks (in enough of
    /// their scans, this one included) that have no point: a far
    /// landmark's nearly parallel rays never bound its depth. The filter
    /// brings them in only where the delayed initializer, given the same
    /// first and newest bearings, would enter a known landmark from its
    /// current bearing by the far rule (24); a known landmark's candidate
    /// needs no point for that either. The sightings must fit one world
    /// direction, as a far point's do (their weighted mean, within the χ²
    /// consistency limit).
    /// Ascending ids; none when a confirmation rule that needs a point is
    /// on.
    #[must_use]
    pub fn ready_without_point(&self) -> Vec<u64> {
        if self.config.confirm_constrained_depth || self.config.min_parallax_views > 0 {
            return Vec::new();
        }
        self.tracks
            .iter()
            .filter(|t| {
                let timed = self.config.track_max_gap_s.is_some();
                t.point.is_none()
                    && t.hits >= self.config.min_sightings
                    && (timed
                        || t.hits as f64 >= self.config.min_hit_ratio * t.judged_scans(self.scan))
                    && t.last().key.0 == self.scan
            })
            .filter(|t| self.fits_one_direction(t))
            .filter(|t| !self.config.confirm_unambiguous || !self.outranked(t))
            .filter(|t| !self.config.confirm_track_score || t.score >= self.score_threshold)
            .map(|t| t.id)
            .collect()
    }

    /// Whether a track's sightings fit a point at infinity, the far rule's
    /// hypothesis: one world direction, their weighted mean, within the
    /// χ² consistency limit (n − 1 degrees of freedom; each bearing's
    /// noise plus the heading variance gained since the first sighting).
    /// A far landmark's bearings do; a moving object's, which swing, and
    /// clutter's, which scatter across the wedge, do not.
    fn fits_one_direction(&self, t: &Track) -> bool {
        let first = t.first();
        let weights: Vec<(f64, f64)> = t
            .sightings
            .iter()
            .map(|s| {
                let grown = relative_variances(first, s);
                (
                    wrap_angle(s.world_bearing() - first.world_bearing()),
                    1.0 / (self.bearing_variance + grown.z),
                )
            })
            .collect();
        let total: f64 = weights.iter().map(|w| w.1).sum();
        let mean = weights.iter().map(|(r, w)| r * w).sum::<f64>() / total;
        let chi2: f64 = weights.iter().map(|(r, w)| (r - mean).powi(2) * w).sum();
        let dof = t.sightings.len().saturating_sub(1).clamp(1, MAX_SIGHTINGS);
        chi2 <= self.consistency[dof]
    }

    /// Whether the two sightings the initializer triangulates from, the
    /// first and the newest (21)–(23), each fit the track's point on their
    /// own (χ²₁ within the gate): a track fitted over many sightings can
    /// take one bearing of another landmark while its point is loose (a
    /// landmark coming into view beside it), and the sum of its residuals
    /// then hides it; triangulated from that bearing, the landmark would be
    /// placed where neither is. A track without a point passes.
    fn ends_fit_point(&self, t: &Track) -> bool {
        let Some((x, _)) = &t.point else {
            return true;
        };
        let first = t.first();
        self.residual2(first, first, x) <= self.gate
            && self.residual2(first, t.last(), x) <= self.gate
    }

    /// Whether the track's point is well constrained: its depth σ from the
    /// latest pose, times `√χ²₂(p)`, is below the depth (the point's χ²₂
    /// ellipse does not reach the robot).
    fn depth_constrained(&self, t: &Track) -> bool {
        let Some((x, cov)) = &t.point else {
            return false;
        };
        let d = x - t.last().position();
        let depth = d.norm();
        if depth < 1e-9 {
            return false;
        }
        let radial = d / depth;
        let sigma = radial.dot(&(cov * radial)).max(0.0).sqrt();
        sigma * self.gate2.sqrt() < depth
    }

    /// Whether another live track with a different point competes for one
    /// of `t`'s sightings and is better supported: more sightings, or as
    /// many with a smaller χ² per degree of freedom. Of two tracks that
    /// claim the same bearings only the better supported may enter the map.
    fn outranked(&self, t: &Track) -> bool {
        let per_dof = |x: &Track| x.chi2 / x.sightings.len().saturating_sub(2).max(1) as f64;
        self.tracks.iter().any(|o| {
            o.id != t.id
                && o.point.is_some()
                && o.chi2.is_finite()
                && o.shares_with(t) > 0
                && !same_point(o, t, self.gate)
                && (o.sightings.len() > t.sightings.len()
                    || (o.sightings.len() == t.sightings.len() && per_dof(o) < per_dof(t)))
        })
    }
}

/// How many of the track's sightings see its point from distinct
/// directions: counted greedily, oldest first, a sighting counts when its
/// ray's direction at the point differs from every counted one's by at
/// least `separation` (rad). 0 without a point. Clutter is independent per
/// scan, so clutter bearings that fit one point from several such views are
/// improbable; a nearly parallel bundle of rays counts once.
fn parallax_views(t: &Track, separation: f64) -> usize {
    let Some((x, _)) = &t.point else {
        return 0;
    };
    let mut counted: Vec<f64> = Vec::new();
    for s in &t.sightings {
        let d = x - s.position();
        let direction = d.y.atan2(d.x);
        if counted
            .iter()
            .all(|&c| wrap_angle(direction - c).abs() >= separation)
        {
            counted.push(direction);
        }
    }
    counted.len()
}
