//! The tool's target path: a piecewise-linear offset over time.

/// Offsets `[dx, dy, dz]` (m) at times `t` (s), linearly interpolated between
/// the points, held at the first point before it and at the last after it.
#[derive(Debug, Clone, PartialEq)]
pub struct ToolPath {
    /// `[t, dx, dy, dz]` with strictly increasing `t` (validated by the scene file).
    points: Vec<[f64; 4]>,
}

impl ToolPath {
    /// A path through `points` (`[t, dx, dy, dz]`, times strictly increasing,
    /// at least one point).
    pub fn new(points: Vec<[f64; 4]>) -> Self {
        Self { points }
    }

    /// Time of the last point (s): the target stays put after it.
    pub fn end_time(&self) -> f64 {
        self.points.last().map_or(0.0, |p| p[0])
    }

    /// The offset at time `t` (s).
    pub fn offset(&self, t: f64) -> [f64; 3] {
        let xyz = |p: &[f64; 4]| [p[1], p[2], p[3]];
        let (Some(first), Some(last)) = (self.points.first(), self.points.last()) else {
            return [0.0; 3];
        };
        if t <= first[0] {
            return xyz(first);
        }
        if t >= last[0] {
            return xyz(last);
        }
        // First point strictly after t; it has a predecessor since t > first[0].
        let i = self.points.partition_point(|p| p[0] <= t);
        let (a, b) = (self.points[i - 1], self.points[i]);
        let s = (t - a[0]) / (b[0] - a[0]);
        [1, 2, 3].map(|k| a[k] + s * (b[k] - a[k]))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_and_holds() {
        let p = ToolPath::new(vec![
            [0.1, 0.0, 0.0, 0.0],
            [0.3, 2.0, -4.0, 1.0],
            [0.4, 2.0, 0.0, 1.0],
        ]);
        assert_eq!(p.offset(0.0), [0.0; 3]);
        assert_eq!(p.offset(0.1), [0.0; 3]);
        let mid = p.offset(0.2);
        assert!((mid[0] - 1.0).abs() < 1e-12 && (mid[1] + 2.0).abs() < 1e-12);
        assert_eq!(p.offset(0.3), [2.0, -4.0, 1.0]);
        assert_eq!(p.offset(5.0), [2.0, 0.0, 1.0]);
        assert_eq!(p.end_time(), 0.4);
    }

    #[test]
    fn single_point_is_constant() {
        let p = ToolPath::new(vec![[0.0, 1.0, 2.0, 3.0]]);
        assert_eq!(p.offset(-1.0), [1.0, 2.0, 3.0]);
        assert_eq!(p.offset(10.0), [1.0, 2.0, 3.0]);
    }
}
