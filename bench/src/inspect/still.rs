//! The inspector's view at one tick, as a PNG (for the docs and CI): what the page draws, without
//! the page.

use std::collections::HashMap;
use std::path::Path;

use plotters::prelude::*;

use crate::error::{BenchError, BenchResult};
use crate::record::{Chunk, Header, Recording, StreamTick};
use crate::scene::SceneShape;

/// What a still shows.
#[derive(Debug, Clone)]
pub struct StillOptions {
    /// The tick (the first recorded at or after it).
    pub tick: u64,
    /// Picture size, px.
    pub size: (u32, u32),
    /// Draw this stream's proxies, outlined in their owners' colours.
    pub world: Option<u16>,
}

/// The page's palette (the same order).
const COLOURS: [RGBColor; 10] = [
    RGBColor(0x1f, 0x77, 0xb4),
    RGBColor(0xd6, 0x27, 0x28),
    RGBColor(0x2c, 0xa0, 0x2c),
    RGBColor(0x94, 0x67, 0xbd),
    RGBColor(0xff, 0x7f, 0x0e),
    RGBColor(0x17, 0xbe, 0xcf),
    RGBColor(0x8c, 0x56, 0x4b),
    RGBColor(0xe3, 0x77, 0xc2),
    RGBColor(0xbc, 0xbd, 0x22),
    RGBColor(0x7f, 0x7f, 0x7f),
];
const HANDOFF: RGBColor = RGBColor(0xf5, 0xb8, 0x00);

fn colour(stream: u16) -> RGBColor {
    COLOURS[stream as usize % COLOURS.len()]
}

/// Ticks a hand-off ring and an op arrow stay drawn after they happen.
const HANDOFF_TICKS: u64 = 30;
const OP_TICKS: u64 = 10;

struct View {
    scale: f64,
    ox: f64,
    oz: f64,
}

impl View {
    fn fit(header: &Header, (w, h): (u32, u32)) -> Self {
        let (mut min_x, mut max_x, mut min_z, mut max_z) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
        for c in &header.clusters {
            let s = f64::from(c.spread);
            min_x = min_x.min(f64::from(c.min[0]) - s);
            max_x = max_x.max(f64::from(c.max[0]) + s);
            min_z = min_z.min(f64::from(c.min[2]) - s);
            max_z = max_z.max(f64::from(c.max[2]) + s);
        }
        if !(max_x - min_x).is_finite() || max_x - min_x > 1e5 || max_z - min_z > 1e5 {
            (min_x, max_x, min_z, max_z) = (-50.0, 50.0, -50.0, 50.0);
        }
        let pad = 12.0;
        let top = 28.0;
        let (w, h) = (f64::from(w) - 2.0 * pad, f64::from(h) - 2.0 * pad - top);
        let scale = (w / (max_x - min_x)).min(h / (max_z - min_z));
        Self {
            scale,
            ox: pad - min_x * scale + (w - (max_x - min_x) * scale) / 2.0,
            oz: pad + top - min_z * scale + (h - (max_z - min_z) * scale) / 2.0,
        }
    }

    fn at(&self, x: f32, z: f32) -> (i32, i32) {
        (
            (self.ox + f64::from(x) * self.scale).round() as i32,
            (self.oz + f64::from(z) * self.scale).round() as i32,
        )
    }

    /// The outline of `shape` at `(x, z)` turned by `heading`.
    fn outline(&self, shape: &SceneShape, x: f32, z: f32, heading: u8) -> Vec<(i32, i32)> {
        let (cx, cz) = (
            self.ox + f64::from(x) * self.scale,
            self.oz + f64::from(z) * self.scale,
        );
        let corners: Vec<(f64, f64)> = match shape.footprint() {
            Some([x, z]) => {
                let hx = (f64::from(x) * self.scale).max(0.75);
                let hz = (f64::from(z) * self.scale).max(0.75);
                vec![(hx, hz), (-hx, hz), (-hx, -hz), (hx, -hz)]
            }
            None => {
                let r = (f64::from(shape.radius()) * self.scale).max(1.2);
                (0..12)
                    .map(|k| {
                        let a = f64::from(k) / 12.0 * std::f64::consts::TAU;
                        (r * a.cos(), r * a.sin())
                    })
                    .collect()
            }
        };
        let a = f64::from(heading) / 256.0 * std::f64::consts::TAU;
        let (co, si) = (a.cos(), a.sin());
        corners
            .into_iter()
            .map(|(u, v)| {
                (
                    (cx + co * u - si * v).round() as i32,
                    (cz + si * u + co * v).round() as i32,
                )
            })
            .collect()
    }
}

/// Draws `recording` at `options.tick` into a PNG at `out`; returns the tick drawn.
pub fn render_still(recording: &Recording, options: &StillOptions, out: &Path) -> BenchResult<u64> {
    crate::sweep::charts::chart_font()?;
    let header = &recording.header;
    let ticks: Vec<u64> = {
        let mut t: Vec<u64> = recording.chunks.iter().map(Chunk::tick).collect();
        t.sort_unstable();
        t.dedup();
        t
    };
    let tick = *ticks
        .iter()
        .find(|&&t| t >= options.tick)
        .or(ticks.last())
        .ok_or(crate::record::RecordError::Empty)?;
    let reference = header.reference_stream();
    let mut slot: HashMap<u16, &StreamTick> = HashMap::new();
    for chunk in &recording.chunks {
        if let Chunk::Tick(t) = chunk
            && t.tick == tick
        {
            slot.insert(t.stream, t);
        }
    }
    // Where each owner has each entity at this tick.
    let mut pose = Pose::new();
    for (&stream, t) in &slot {
        if Some(stream) == reference {
            continue;
        }
        for p in &t.owned {
            let [x, _, z] = p.position();
            pose.insert(p.entity, (x, z, p.heading, stream));
        }
    }
    let root = BitMapBackend::new(out, options.size).into_drawing_area();
    let fail = |e: &dyn std::fmt::Display| BenchError::Chart {
        chart: out.display().to_string(),
        problem: e.to_string(),
    };
    root.fill(&WHITE).map_err(|e| fail(&e))?;
    let view = View::fit(header, options.size);
    let canvas = Canvas {
        root: &root,
        view: &view,
        fail: &fail,
    };
    canvas.regions(header)?;
    canvas.scenery(header)?;
    canvas.bodies(header, &slot, reference)?;
    if let Some(world) = options.world
        && let Some(t) = slot.get(&world)
    {
        canvas.proxies(header, t, &pose)?;
    }
    canvas.handoffs(recording, tick, &pose)?;
    canvas.ops(recording, tick, &pose)?;
    let title = format!(
        "{} · {} · tick {tick} · {} owned",
        header.scene,
        header.source,
        pose.len()
    );
    root.draw(&Text::new(
        title,
        (12, 8),
        ("sans-serif", 16).into_font().color(&BLACK),
    ))
    .map_err(|e| fail(&e))?;
    root.present().map_err(|e| fail(&e))?;
    Ok(tick)
}

/// The image a still is drawn on.
type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

/// Makes a drawing error a [`BenchError`].
type Fail<'f> = dyn Fn(&dyn std::fmt::Display) -> BenchError + 'f;

/// What a still is drawn on: the image, the view onto the world, and how a drawing error is
/// said.
struct Canvas<'a, 'b> {
    root: &'a Area<'b>,
    view: &'a View,
    fail: &'a Fail<'a>,
}

/// Where each owner has each entity at a tick: x, z, heading, stream.
type Pose = HashMap<u32, (f32, f32, u8, u16)>;

impl Canvas<'_, '_> {
    /// Each cluster's region, tinted, its interest margin outlined, its name in a corner.
    fn regions(&self, header: &Header) -> BenchResult<()> {
        for (i, c) in header.clusters.iter().enumerate() {
            let col = colour(i as u16);
            let a = self.view.at(c.min[0], c.min[2]);
            let b = self.view.at(c.max[0], c.max[2]);
            self.root
                .draw(&Rectangle::new([a, b], col.mix(0.08).filled()))
                .map_err(|e| (self.fail)(&e))?;
            self.root
                .draw(&Rectangle::new([a, b], col.stroke_width(1)))
                .map_err(|e| (self.fail)(&e))?;
            let s = c.spread;
            let sa = self.view.at(c.min[0] - s, c.min[2] - s);
            let sb = self.view.at(c.max[0] + s, c.max[2] + s);
            self.root
                .draw(&Rectangle::new([sa, sb], col.mix(0.35).stroke_width(1)))
                .map_err(|e| (self.fail)(&e))?;
            self.root
                .draw(&Text::new(
                    c.name.clone(),
                    (a.0 + 4, a.1 + 4),
                    ("sans-serif", 14).into_font().color(&col),
                ))
                .map_err(|e| (self.fail)(&e))?;
        }
        Ok(())
    }

    /// The scenery every cluster loads, faint.
    fn scenery(&self, header: &Header) -> BenchResult<()> {
        let shape_of = |entity: u32| header.group_of(entity).map(|g| g.shape.clone());
        for p in &header.scenery {
            if let Some(shape) = shape_of(p.entity) {
                let outline = self
                    .view
                    .outline(&shape, p.position[0], p.position[2], p.heading);
                self.root
                    .draw(&Polygon::new(outline, BLACK.mix(0.13).filled()))
                    .map_err(|e| (self.fail)(&e))?;
            }
        }
        Ok(())
    }

    /// Every stream's owned bodies in its colour.
    fn bodies(
        &self,
        header: &Header,
        slot: &HashMap<u16, &StreamTick>,
        reference: Option<u16>,
    ) -> BenchResult<()> {
        let mut streams: Vec<&u16> = slot.keys().collect();
        streams.sort();
        // Fixed bodies (floors, walls) first and faint, so what moves shows on top of them.
        for fixed in [true, false] {
            for &stream in &streams {
                if Some(*stream) == reference {
                    continue;
                }
                let col = colour(*stream);
                for p in &slot[stream].owned {
                    let Some(group) = header.group_of(p.entity) else {
                        continue;
                    };
                    if (group.role == "fixed") != fixed {
                        continue;
                    }
                    let [x, _, z] = p.position();
                    let outline = self.view.outline(&group.shape, x, z, p.heading);
                    let style = if fixed {
                        col.mix(0.18).filled()
                    } else {
                        col.filled()
                    };
                    self.root
                        .draw(&Polygon::new(outline, style))
                        .map_err(|e| (self.fail)(&e))?;
                }
            }
        }
        Ok(())
    }

    /// The proxies world `t` holds, outlined in their owner's colour where their owner has them.
    fn proxies(&self, header: &Header, t: &StreamTick, pose: &Pose) -> BenchResult<()> {
        let shape_of = |entity: u32| header.group_of(entity).map(|g| g.shape.clone());
        for e in &t.proxies {
            let (Some(&(x, z, heading, owner)), Some(shape)) = (pose.get(e), shape_of(*e)) else {
                continue;
            };
            let mut outline = self.view.outline(&shape, x, z, heading);
            outline.push(outline[0]);
            self.root
                .draw(&PathElement::new(outline, colour(owner).stroke_width(2)))
                .map_err(|e| (self.fail)(&e))?;
        }
        Ok(())
    }

    /// Recent hand-offs ringed, fading with age; a body in transit outlined where it was last
    /// owned.
    fn handoffs(&self, recording: &Recording, tick: u64, pose: &Pose) -> BenchResult<()> {
        let header = &recording.header;
        let reference = header.reference_stream();
        let shape_of = |entity: u32| header.group_of(entity).map(|g| g.shape.clone());
        // Where each entity was last owned up to this tick, for bodies in a hand-off now.
        let mut latest: HashMap<u32, (f32, f32, u8, u64)> = HashMap::new();
        for chunk in &recording.chunks {
            if let Chunk::Tick(t) = chunk
                && t.tick <= tick
                && Some(t.stream) != reference
            {
                for p in &t.owned {
                    let [x, _, z] = p.position();
                    latest.insert(p.entity, (x, z, p.heading, t.tick));
                }
            }
        }
        // Hand-offs: an entity taken, or whose owning stream changed, in the last ticks; one owned
        // by nobody after this tick (in transit) outlined where it was last owned.
        for (entity, at) in handoffs_before(recording, tick, HANDOFF_TICKS) {
            let place = match pose.get(&entity) {
                Some(&(x, z, _, _)) => Some((x, z)),
                None => match (latest.get(&entity), shape_of(entity)) {
                    (Some(&(x, z, heading, seen)), Some(shape)) if seen + HANDOFF_TICKS >= tick => {
                        let mut outline = self.view.outline(&shape, x, z, heading);
                        outline.push(outline[0]);
                        self.root
                            .draw(&PathElement::new(outline, BLACK.mix(0.7).stroke_width(1)))
                            .map_err(|e| (self.fail)(&e))?;
                        Some((x, z))
                    }
                    _ => None,
                },
            };
            if let Some((x, z)) = place {
                let age = (tick - at) as f64 / HANDOFF_TICKS as f64;
                let r = (8.0 + 22.0 * (1.0 - age)) as i32;
                self.root
                    .draw(&Circle::new(self.view.at(x, z), r, HANDOFF.stroke_width(3)))
                    .map_err(|e| (self.fail)(&e))?;
            }
        }
        Ok(())
    }

    /// Ops routed in the last ticks, a line from their sender's region to their target.
    fn ops(&self, recording: &Recording, tick: u64, pose: &Pose) -> BenchResult<()> {
        let header = &recording.header;
        for chunk in &recording.chunks {
            let Chunk::Tick(t) = chunk else { continue };
            if t.tick > tick || t.tick + OP_TICKS < tick {
                continue;
            }
            for op in &t.ops {
                let (Some(from), Some(&(x, z, _, _))) = (op.from, pose.get(&op.target)) else {
                    continue;
                };
                let Some(c) = header.clusters.get(from as usize) else {
                    continue;
                };
                let start = self
                    .view
                    .at((c.min[0] + c.max[0]) / 2.0, (c.min[2] + c.max[2]) / 2.0);
                self.root
                    .draw(&PathElement::new(
                        vec![start, self.view.at(x, z)],
                        colour(from).stroke_width(2),
                    ))
                    .map_err(|e| (self.fail)(&e))?;
            }
        }
        Ok(())
    }
}

/// Entities taken in a hand-off, or whose owning stream changed, within `window` ticks up to
/// `tick`, with the tick.
fn handoffs_before(recording: &Recording, tick: u64, window: u64) -> Vec<(u32, u64)> {
    let reference = recording.header.reference_stream();
    let mut owner: HashMap<u32, u16> = HashMap::new();
    let mut found = Vec::new();
    for chunk in &recording.chunks {
        let Chunk::Tick(t) = chunk else { continue };
        if t.tick > tick || Some(t.stream) == reference {
            continue;
        }
        let recent = t.tick + window >= tick;
        for h in t.handoffs.iter().filter(|h| h.taken) {
            if recent {
                found.push((h.entity, t.tick));
            }
            owner.insert(h.entity, t.stream);
        }
        for p in &t.owned {
            let before = owner.insert(p.entity, t.stream);
            if before.is_some_and(|b| b != t.stream) && recent {
                found.push((p.entity, t.tick));
            }
        }
    }
    found.sort_unstable();
    found.dedup();
    found
}
