//! The per-sample visibility solver: for one sample V, find every object
//! that the shrunk occluders do not hide from V, growing the near-field
//! cull map only while something beyond it may still be visible
//! (METHOD.md 5 and 6).

use glam::DVec2;

use super::bitset::ObjectSet;
use super::cullmap::CullWindow;
use super::horizon::Horizon;
use super::index::SceneIndex;
use crate::model::{Rect, distance_to_segment};

/// The near-field half-sizes tried, in metres, smallest first. Objects still
/// unresolved at the largest are counted visible.
pub const NEAR_FIELD_RADII: [f64; 5] = [40.0, 80.0, 160.0, 320.0, 640.0];

/// Reusable per-thread state for solving samples.
pub struct Solver<'a> {
    index: &'a SceneIndex,
    eye: f64,
    pub window: CullWindow,
    horizon: Horizon,
    edge_stamp: Vec<u32>,
    stamp: u32,
    gathered: Vec<(f64, u32)>,
    unresolved: Vec<u32>,
    stack: Vec<u32>,
    /// Largest near-field radius to try.
    max_radius: f64,
}

/// Where an object stands after one window.
enum Verdict {
    Visible,
    Hidden,
    Unresolved,
}

impl<'a> Solver<'a> {
    pub fn new(index: &'a SceneIndex, eye: f64, max_radius: f64) -> Self {
        Solver {
            index,
            eye,
            window: CullWindow::new(index.grid),
            horizon: Horizon::default(),
            edge_stamp: vec![0; index.edges.len()],
            stamp: 0,
            gathered: Vec::new(),
            unresolved: Vec::new(),
            stack: Vec::new(),
            max_radius,
        }
    }

    /// Add to `visible` every object not hidden from the sample at `v`.
    pub fn solve(&mut self, v: DVec2, visible: &mut ObjectSet) {
        let mut first = true;
        let mut pending: Vec<u32> = Vec::new();
        for &radius in NEAR_FIELD_RADII.iter() {
            let last = radius >= self.max_radius || radius == *NEAR_FIELD_RADII.last().unwrap();
            self.window.reset_around(v, radius);
            self.rasterise_occluders(v);
            self.unresolved.clear();
            if first {
                self.traverse(v, visible);
                first = false;
            } else {
                for &o in &pending {
                    if !visible.contains(o as usize) {
                        self.classify(v, o, visible);
                    }
                }
            }
            if self.unresolved.is_empty() {
                return;
            }
            if last {
                for &o in &self.unresolved {
                    visible.insert(o as usize);
                }
                return;
            }
            pending.clear();
            pending.extend_from_slice(&self.unresolved);
        }
    }

    /// Fill the window with U_V and the horizon from the occluder edges that
    /// reach into the window, nearest first, dropping edges already hidden.
    pub fn rasterise_occluders(&mut self, v: DVec2) {
        let index = self.index;
        let rect = self.window.rect();
        self.stamp = self.stamp.wrapping_add(1);
        if self.stamp == 0 {
            self.edge_stamp.fill(0);
            self.stamp = 1;
        }
        self.gathered.clear();
        let (stamp, edge_stamp, gathered) = (self.stamp, &mut self.edge_stamp, &mut self.gathered);
        index.edges_near(&rect, |e| {
            if edge_stamp[e as usize] != stamp {
                edge_stamp[e as usize] = stamp;
                let edge = &index.edges[e as usize];
                gathered.push((distance_to_segment(v, edge.a, edge.b), e));
            }
        });
        self.gathered
            .sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
        self.horizon.clear();
        let inside = |p: DVec2| {
            p.x >= rect.min.x && p.x <= rect.max.x && p.y >= rect.min.y && p.y <= rect.max.y
        };
        for &(_, e) in &self.gathered {
            let edge = &index.edges[e as usize];
            // The solid is on the edge's left; the eye faces the edge's outside
            // when it is on its right.
            let eye_outside = (edge.b - edge.a).perp_dot(v - edge.a) < 0.0;
            let silhouette = if edge.height > self.eye {
                eye_outside
            } else {
                !eye_outside
            };
            if silhouette && !self.window.segment_hidden(edge.a, edge.b, edge.height) {
                self.window
                    .rasterise_shadow(v, self.eye, edge.a, edge.b, edge.height);
            }
            if edge.height > self.eye && inside(edge.a) {
                // A chain along the ring from this edge, while inside the window.
                let mut chain_end = e;
                let chain = std::iter::once(edge.a).chain(std::iter::from_fn(|| {
                    let current = &index.edges[chain_end as usize];
                    if !inside(current.b) {
                        return None;
                    }
                    chain_end = current.next;
                    Some(current.b)
                }));
                self.horizon.add_chain(v, self.eye, edge.height, chain);
            }
        }
    }

    fn traverse(&mut self, v: DVec2, visible: &mut ObjectSet) {
        let Some(root) = self.index.root else { return };
        let index = self.index;
        let window = self.window.rect();
        self.stack.clear();
        self.stack.push(root);
        while let Some(n) = self.stack.pop() {
            let node = &index.pyramid[n as usize];
            if !node.rect.intersects(&window)
                && self
                    .horizon
                    .hides_rect(v, self.eye, &node.rect, node.max_height)
            {
                continue;
            }
            self.stack.extend(node.children.iter().rev());
            for &o in &node.objects {
                if !visible.contains(o as usize) {
                    self.classify(v, o, visible);
                }
            }
        }
    }

    fn classify(&mut self, v: DVec2, o: u32, visible: &mut ObjectSet) {
        match self.verdict(v, o) {
            Verdict::Visible => visible.insert(o as usize),
            Verdict::Hidden => {}
            Verdict::Unresolved => self.unresolved.push(o),
        }
    }

    fn verdict(&self, v: DVec2, o: u32) -> Verdict {
        let object = &self.index.objects[o as usize];
        let window = self.window.rect();
        let mut outside = false;
        // Pixels outside the window are the horizon's business below.
        if object.rect.intersects(&window)
            && !self
                .window
                .spans_hidden(&object.spans, object.height, &mut outside)
        {
            return Verdict::Visible;
        }
        if !contains(&window, &object.rect) {
            if !self
                .horizon
                .hides_rect(v, self.eye, &object.rect, object.height)
            {
                return Verdict::Unresolved;
            }
        }
        Verdict::Hidden
    }
}

fn contains(outer: &Rect, inner: &Rect) -> bool {
    inner.min.x >= outer.min.x
        && inner.min.y >= outer.min.y
        && inner.max.x <= outer.max.x
        && inner.max.y <= outer.max.y
}
