//! Work counters of a render: paths and rays by kind, and the samples
//! and paths that something went wrong with. Below the integrator and the
//! estimators that count into them ([`crate::integrator`],
//! `crate::highlight`), and above nothing.

/// Work counters of a render: paths and rays by kind.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Stats {
    /// Path samples (one camera ray each).
    pub paths: u64,
    /// Rays traced for closest hits after the camera ray (and the rays of
    /// [`crate::highlight`]'s samples, which have no path of their own).
    pub bounce_rays: u64,
    /// Shadow rays (occlusion tests toward a light).
    pub shadow_rays: u64,
    /// Samples whose radiance was NaN, infinite or above
    /// [`crate::render::SAMPLE_MAX`] (counted, then dropped).
    pub nonfinite: u64,
    /// Rays that escaped a closed scene: numerical leaks (should be 0).
    pub leaks: u64,
    /// Paths (or branches of a path split at glass) that the depth cap
    /// [`crate::integrator::Options::max_depth`] ended: each drops whatever light it would
    /// still have found, a bias (should be 0).
    pub truncated: u64,
}

impl Stats {
    /// All rays: camera + bounce + shadow.
    pub fn rays(&self) -> u64 {
        self.paths + self.bounce_rays + self.shadow_rays
    }

    /// Adds another set of counters to this one.
    pub fn merge(&mut self, o: &Stats) {
        self.paths += o.paths;
        self.bounce_rays += o.bounce_rays;
        self.shadow_rays += o.shadow_rays;
        self.nonfinite += o.nonfinite;
        self.leaks += o.leaks;
        self.truncated += o.truncated;
    }
}
