//! Right-multiplication by a change of variables that is the identity but
//! for pose-anchored landmarks: what turns a linear prior's `R` into its
//! Jacobian at the estimate ([`super::LinearFactor`]'s chain rule
//! `∂u/∂p ∂p/∂δ`) and into the prior's own chart (the marginalization's
//! change of variables `δ = T z`). Both couple a landmark's two columns
//! only to its own and to its anchor pose's `[x, y]` columns, so `A G` is
//! `n` work per landmark by column operations where a dense `G` would be
//! an `n³` product.

use nalgebra::{DMatrix, Matrix2};

/// One pose-anchored landmark's blocks of `G`: its columns' offset, its
/// anchor pose's, and `G`'s 2 × 2 blocks from the landmark's increments to
/// its own (`on_landmark`) and to the anchor's `[x, y]` (`on_anchor`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct AnchorLink {
    pub landmark: usize,
    pub anchor: usize,
    pub on_landmark: Matrix2<f64>,
    pub on_anchor: Matrix2<f64>,
}

/// `A ← A G`: each landmark's columns become `A_l on_landmark` and
/// `A_l on_anchor` is added to its anchor's `[x, y]` columns, `A_l` read
/// before it is replaced (a landmark is never an anchor).
pub(crate) fn right_multiply(a: &mut DMatrix<f64>, links: &[AnchorLink]) {
    for link in links {
        let landmark = a.columns(link.landmark, 2).clone_owned();
        let mut anchor_xy = a.columns_mut(link.anchor, 2);
        anchor_xy += &landmark * link.on_anchor;
        a.columns_mut(link.landmark, 2)
            .copy_from(&(landmark * link.on_landmark));
    }
}
