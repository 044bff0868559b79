//! Labels beside points without overlap: a greedy placement over candidate positions with
//! bounding-box tests. A label that finds no free spot is dropped, never drawn over another
//! label or a point (the printed table still lists every point).

/// Pixel rectangle `(x0, y0, x1, y1)`, `x0 < x1`, `y0 < y1`.
pub(super) type Bounds = (i32, i32, i32, i32);

/// Whether two rectangles share any area (touching edges do not count).
pub(super) fn overlaps(a: Bounds, b: Bounds) -> bool {
    a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
}

/// Whether `inner` lies inside `outer`.
fn inside(inner: Bounds, outer: Bounds) -> bool {
    inner.0 >= outer.0 && inner.2 <= outer.2 && inner.1 >= outer.1 && inner.3 <= outer.3
}

/// The box of a round marker of `radius` pixels centred on `(x, y)`.
pub(super) fn marker_box((x, y): (i32, i32), radius: i32) -> Bounds {
    (x - radius, y - radius, x + radius + 1, y + radius + 1)
}

/// A label wanted beside a point.
#[derive(Debug, Clone, Copy)]
pub(super) struct Wanted {
    /// The point, in pixels.
    pub(super) anchor: (i32, i32),
    /// Distance from the point to the nearest edge of the label.
    pub(super) gap: i32,
    /// The label's measured width and height.
    pub(super) size: (i32, i32),
}

/// Candidate boxes around the anchor, best first: the four diagonals, above and below,
/// right and left, then the same twice and three times as far.
fn candidates(w: &Wanted) -> Vec<Bounds> {
    let (px, py) = w.anchor;
    let (width, height) = w.size;
    let mut spots = Vec::with_capacity(24);
    for reach in 1..=3 {
        let gap = w.gap * reach;
        spots.extend(
            [
                (px + gap, py - gap - height),
                (px - gap - width, py - gap - height),
                (px + gap, py + gap),
                (px - gap - width, py + gap),
                (px - width / 2, py - gap - height),
                (px - width / 2, py + gap),
                (px + gap + 2, py - height / 2),
                (px - gap - 2 - width, py - height / 2),
            ]
            .map(|(x, y)| (x, y, x + width, y + height)),
        );
    }
    spots
}

/// Places the labels in order (earlier ones win): each takes the first candidate spot that
/// lies inside `within` and overlaps no obstacle (markers) and no label placed before it,
/// preferring among those the spots that cover the fewest `soft` boxes (lines, which a label
/// may cross). Returns one box per label, `None` for a label dropped for want of room.
pub(super) fn place_labels(
    wanted: &[Wanted],
    obstacles: &[Bounds],
    soft: &[Bounds],
    within: Bounds,
) -> Vec<Option<Bounds>> {
    let mut placed: Vec<Bounds> = Vec::with_capacity(wanted.len());
    wanted
        .iter()
        .map(|w| {
            let free = |b: &Bounds| {
                inside(*b, within)
                    && obstacles.iter().all(|o| !overlaps(*b, *o))
                    && placed.iter().all(|p| !overlaps(*b, *p))
            };
            let crossings = |b: &Bounds| soft.iter().filter(|s| overlaps(*b, **s)).count();
            let spot = candidates(w)
                .into_iter()
                .filter(free)
                .enumerate()
                // Fewest crossings first, then the earlier (nearer) candidate.
                .min_by_key(|(k, b)| (crossings(b), *k))
                .map(|(_, b)| b);
            if let Some(b) = spot {
                placed.push(b);
            }
            spot
        })
        .collect()
}

/// Boxes of `radius` pixels every few pixels along a polyline, for [`place_labels`]' `soft`.
pub(super) fn polyline_boxes(points: &[(i32, i32)], radius: i32) -> Vec<Bounds> {
    let mut boxes = Vec::new();
    for pair in points.windows(2) {
        let ((ax, ay), (bx, by)) = (pair[0], pair[1]);
        let steps = ((bx - ax).abs().max((by - ay).abs()) / 4).max(1);
        for k in 0..=steps {
            let x = ax + (bx - ax) * k / steps;
            let y = ay + (by - ay) * k / steps;
            boxes.push((x - radius, y - radius, x + radius, y + radius));
        }
    }
    boxes
}
