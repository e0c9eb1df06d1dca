//! The tet walk in packets: a chunk's runs of rays sharing an origin, started together where
//! they enter the box, stepped as one while they leave each tet by one face (the module's
//! text in `tetwalk.rs` has the whole story).

use super::{Lane, TetWalk, MIN_PACKET, PACKET};
use crate::geom::ray::Ray;
use crate::geom::real::Real;
use crate::layout::Layout;
use crate::locate::{ExactOrigin, LocateState, WalkStart, GRAZES};
use crate::mesh::build::OUTWARD_FACES;
use crate::query::{QueryKind, Sink};
use crate::traverse::packet::{seen_from, DirBox, Edge, Packet, PacketRay};
use crate::traverse::{entry_face, ExitMethod, WalkObserver, WalkState};

test_count!(
    /// Packet steps taken so far on this thread (tests check that packets walked at all).
    PACKET_STEPS,
    packet_steps
);

test_count!(
    /// Rays started together by their run's entry face so far on this thread (tests check
    /// it ran).
    ENTERED_TOGETHER,
    entered_together
);

#[inline(always)]
fn count_packet_step() {
    test_count!(PACKET_STEPS += 1);
}

/// A packet's rays and the room to regroup them (kept from packet to packet).
#[derive(Default)]
struct PacketRays {
    /// Index into the run, and the ray's direction (as its walk's line has it).
    rays: Vec<PacketRay>,
    spare: Vec<PacketRay>,
    exits: Vec<u8>,
    stack: Vec<(usize, usize, Packet)>,
}

/// A run's rays (one origin, at most [`PACKET`]): those started alone, and those entering the
/// box together ([`TetWalk::enter_together`]: the index in the chunk, the ray and its line,
/// not yet prepared for its walk). A packet names them by index, `ENTERING` marking the
/// second kind (kept apart: a located ray is a sixth of a started one's size, which packets
/// move).
struct Run<R: Real, M: ExitMethod<R>, P, O> {
    started: Vec<Lane<R, M, P, O>>,
    entering: Vec<(usize, WalkStart)>,
    /// One entering ray prepared: the others are its redirections (`ExitMethod::redirect`).
    prepared: Option<M::Ray>,
}

const ENTERING: u32 = 1 << 31;

impl<R: Real, M: ExitMethod<R>, P, O> Default for Run<R, M, P, O> {
    fn default() -> Self {
        Run {
            started: Vec::with_capacity(PACKET),
            entering: Vec::with_capacity(PACKET),
            prepared: None,
        }
    }
}

impl<R: Real, M: ExitMethod<R>, P, O> Run<R, M, P, O> {
    /// Ray i's line (origin, direction as the walk has it).
    fn line(&self, i: u32) -> ([f64; 3], [f64; 3]) {
        if i & ENTERING != 0 {
            let s = &self.entering[(i & !ENTERING) as usize].1;
            (s.o, s.dir)
        } else {
            M::line(
                &self.started[i as usize]
                    .as_ref()
                    .expect("a started ray")
                    .1
                    .prepared,
            )
        }
    }
}

impl<R: Real, L: Layout, M: ExitMethod<R>, O: WalkObserver<R>> TetWalk<'_, R, L, M, O> {
    /// The chunk in packets: runs of rays sharing an origin (at most [`PACKET`]) are started
    /// (the first alone, the others together where they enter the box by its face, else one
    /// by one), grouped by the face their walks stand at, and each group walks as one packet
    /// ([`TetWalk::walk_packet`]); every ray finishes with its own walk from where its packet
    /// left it.
    pub(super) fn trace_packets<K: QueryKind, S: Sink<K::Answer>>(
        &self,
        query: &K,
        ray_at: impl Fn(usize) -> Ray,
        out: &mut S,
        st: &mut LocateState,
    ) {
        let n = out.len();
        // Rays in order of origin, then of direction along a Morton curve: consecutive rays
        // then fill square-ish tiles of the image, whose rays part late.
        let origin0 = ray_at(0).o.map(f64::to_bits);
        let mut one_origin = true;
        let mut by_direction: Vec<u64> = (0..n)
            .map(|j| {
                let ray = ray_at(j);
                one_origin &= ray.o.map(f64::to_bits) == origin0;
                (direction_key(ray.d) as u64) << 32 | j as u64
            })
            .collect();
        if one_origin {
            // Radix passes over the key's bytes (stable: ties keep ray order), a tenth of a
            // comparison sort's work on a chunk.
            radsort::sort_by_key(&mut by_direction, |k| (k >> 32) as u32);
        } else {
            let origin = |k: &u64| ray_at((*k & 0xffff_ffff) as usize).o.map(f64::to_bits);
            by_direction.sort_unstable_by_key(|k| (origin(k), *k));
        }
        let ray_of = |k: usize| (by_direction[k] & 0xffff_ffff) as usize;
        let mut run = Run::default();
        let mut order: Vec<(u32, [u32; 3], u32, u32, u32)> = Vec::with_capacity(PACKET);
        let mut group = PacketRays::default();
        let mut first = 0;
        while first < n {
            // A run: up to PACKET rays from one origin (compared by bits: a NaN origin, an
            // invalid ray, is its own run too).
            let origin = ray_at(ray_of(first)).o.map(f64::to_bits);
            let mut end = first + 1;
            while end < n
                && end - first < PACKET
                && ray_at(ray_of(end)).o.map(f64::to_bits) == origin
            {
                end += 1;
            }
            run.started.clear();
            run.entering.clear();
            run.prepared = None;
            // The run's first ray starts alone; from outside the box, its location remembers
            // the face it entered by, which the others then often all enter by together.
            self.start_alone(query, ray_of(first), &ray_at, out, st, &mut run);
            let entered = self.enter_together(
                query,
                (first + 1..end).map(ray_of),
                &ray_at,
                out,
                st,
                &mut run,
            );
            first = end;
            // Groups: rays whose walks stand at the same face (stable: ray order within).
            // Only the rays started alone (few, when the rest entered together) are sorted;
            // the entering rays, one key in index order, go in as a block where the sort
            // would have put them.
            order.clear();
            order.extend(run.started.iter().enumerate().map(|(i, w)| {
                let s = &w.as_ref().expect("a started ray").1.state;
                (s.link, [s.a, s.b, s.c], s.t, s.steps, i as u32)
            }));
            order.sort_unstable();
            if let Some(key) = entered {
                let first = (key.0, key.1, key.2, key.3, ENTERING);
                let at = order.partition_point(|x| *x < first);
                order.splice(
                    at..at,
                    (0..run.entering.len())
                        .map(|i| (key.0, key.1, key.2, key.3, ENTERING | i as u32)),
                );
            }
            let mut g = 0;
            while g < order.len() {
                let key = |x: &(u32, [u32; 3], u32, u32, u32)| (x.0, x.1, x.2, x.3);
                let end = g + order[g..]
                    .iter()
                    .take_while(|x| key(x) == key(&order[g]))
                    .count();
                let (link, face, t, steps, _) = order[g];
                group.rays.clear();
                group.rays.extend(
                    order[g..end]
                        .iter()
                        .map(|x| PacketRay::new(x.4, run.line(x.4).1)),
                );
                let origin = run.line(order[g].4).0;
                let packet = Packet::new(&self.setup, origin, face, link, t, steps);
                self.walk_packet(query, &mut run, &mut group, origin, packet, out);
                g = end;
            }
        }
    }

    /// Starts ray j alone (located, its walk's first exit taken) into `run.started`, or puts
    /// its answer where it needs no packet.
    #[inline(always)]
    fn start_alone<K: QueryKind, S: Sink<K::Answer>>(
        &self,
        query: &K,
        j: usize,
        ray_at: &impl Fn(usize) -> Ray,
        out: &mut S,
        st: &mut LocateState,
        run: &mut Run<R, M, K::Policy, O>,
    ) {
        let ray = ray_at(j);
        if let Some(w) = self.begin_plain(query, j, &ray, out, st) {
            run.started.push(Some((j, w)));
        }
    }

    /// Starts rays `rays` (one origin) together into `run.entering` where the box of their
    /// directions decides, for all at once, where each one's own start would leave them
    /// (`walk_begin`'s state): from outside the box, entering by the face the last located
    /// ray from there entered by (`LocateState::entered_by_all`); from inside, leaving the
    /// origin's start tet by one face ([`TetWalk::start_exit_of_all`]). Each ray is checked
    /// and its line made as location makes it (`Locators::exact_line`), but none searches for
    /// its start or takes a first exit alone. Returns the walks' common state, as (link,
    /// face, tet, steps); else each ray starts alone and None.
    fn enter_together<K: QueryKind, S: Sink<K::Answer>>(
        &self,
        query: &K,
        rays: impl Iterator<Item = usize>,
        ray_at: &impl Fn(usize) -> Ray,
        out: &mut S,
        st: &mut LocateState,
        run: &mut Run<R, M, K::Policy, O>,
    ) -> Option<(u32, [u32; 3], u32, u32)> {
        if !M::PACKETS {
            for j in rays {
                self.start_alone(query, j, ray_at, out, st, run);
            }
            return None;
        }
        let mut inside = false;
        for j in rays {
            let ray = ray_at(j);
            match self.locators.exact_line(&ray) {
                // A line that may touch the box without entering it: the exact BVH's answer.
                Err(GRAZES) => out.put(j, self.answer_grazing(query, &ray)),
                // Its answer whichever way it starts (location gives the same status).
                Err(status) => out.put(j, query.skipped(status)),
                Ok((start, origin)) => {
                    // One origin: every ray is inside, or every one outside.
                    inside = origin == ExactOrigin::Inside;
                    run.entering.push((j, start));
                }
            }
        }
        let first = &run.entering.first()?.1;
        let dirs = DirBox::of(run.entering.iter().map(|x| &x.1.dir));
        let tets = &self.locators.mesh.tets;
        let together = if inside {
            self.start_exit_of_all(first.o, &dirs, st).map(|(t, i)| {
                // As `walk_begin` leaves the start tet by face i.
                let f = OUTWARD_FACES[i];
                let names = tets[t as usize];
                let face = [names[f[0]], names[f[1]], names[f[2]]];
                let link = self.setup.layout.link_opposite(t, names[i], face);
                (link, face, t, 1)
            })
        } else {
            // As `walk_begin` stands a ray entering from outside: before the entry tet.
            st.entered_by_all(first.o, &dirs)
                .map(|(t, i)| (t, entry_face(tets[t as usize], i), t, 0))
        };
        if together.is_some() {
            run.prepared = Some(M::prepare(first.o, first.dir, &self.locators.mesh.bounds));
            test_count!(ENTERED_TOGETHER += run.entering.len());
            return together;
        }
        let entering = std::mem::take(&mut run.entering);
        for &(j, _) in &entering {
            self.start_alone(query, j, ray_at, out, st, run);
        }
        // Keep the room for the next run.
        run.entering = entering;
        run.entering.clear();
        None
    }

    /// For rays from origin `o` in the box, all with directions in `dirs`: their start tet
    /// and the face each leaves it by, when it is one face for all. The start tet is the one
    /// location found for `o` (`LocateState`'s camera), and only where no ray from `o` can
    /// touch the surface at its origin (`LocateState::origin_may_touch` said so). Then the
    /// exit is the face whose three edges, in outward order, every ray turns positively
    /// around (`Exact::start_exit`'s choice: certain and nonzero, the perturbation never
    /// decides, and no other face can have all three, since neighbouring faces see their
    /// shared edge in opposite orders); with those sides certain no ray touches the face.
    fn start_exit_of_all(
        &self,
        o: [f64; 3],
        dirs: &DirBox,
        st: &LocateState,
    ) -> Option<(u32, usize)> {
        let t = st.origin_cannot_touch(o)?;
        let corners = self.locators.mesh.tets[t as usize];
        let at = corners.map(|v| seen_from(&self.setup, o, v));
        (0..4)
            .find(|&i| {
                let [p, q, r] = OUTWARD_FACES[i].map(|k| at[k]);
                Edge::around(p, q, r).iter().all(|e| e.side(dirs) > 0)
            })
            .map(|i| (t, i))
    }

    /// Walks the rays `group.rays` (one face, one origin) as a packet from `packet`, and
    /// finishes each ray: while the box of their directions leaves each tet by one certain
    /// exit, in one step for all; where it does not, each ray's exit is decided alone (three
    /// dot products with the packet's edges) and the rays are regrouped by exit, each group a
    /// packet again (a trie of the rays' tet paths). A ray whose exit is not certain, or a
    /// group too small, finishes with its own walk.
    fn walk_packet<K: QueryKind, S: Sink<K::Answer>>(
        &self,
        query: &K,
        run: &mut Run<R, M, K::Policy, O>,
        group: &mut PacketRays,
        origin: [f64; 3],
        packet: Packet,
        out: &mut S,
    ) {
        let PacketRays {
            rays,
            spare,
            exits,
            stack,
        } = group;
        exits.resize(rays.len(), 0);
        stack.clear();
        stack.push((0, rays.len(), packet));
        while let Some((lo, hi, mut packet)) = stack.pop() {
            let dirs = DirBox::of(rays[lo..hi].iter().map(|r| &r.dir));
            loop {
                let next = (hi - lo >= MIN_PACKET)
                    .then(|| packet.next(&self.setup, origin))
                    .flatten();
                let Some((d, pd, edges)) = next else {
                    self.finish_rays(query, run, &rays[lo..hi], &packet, out);
                    break;
                };
                if let Some(r) = Packet::exit_of_box(&edges, &dirs) {
                    packet.advance(&self.setup, (d, pd), r);
                    count_packet_step();
                    continue;
                }
                let bounds = edges.map(|e| e.bound(&dirs));
                let mut counts = [0usize; 4];
                let (rays_here, exits_here) = (&rays[lo..hi], &mut exits[lo..hi]);
                Packet::exits_of(
                    &edges,
                    &bounds,
                    rays_here,
                    exits_here,
                    &mut counts,
                    self.simd,
                );
                if let Some(r) = (0..3).find(|&r| counts[r] == hi - lo) {
                    packet.advance(&self.setup, (d, pd), r as u8);
                    count_packet_step();
                    continue;
                }
                // The rays part here: regroup them by exit, in order.
                let mut starts = [lo; 4];
                for r in 1..4 {
                    starts[r] = starts[r - 1] + counts[r - 1];
                }
                spare.clear();
                spare.extend_from_slice(&rays[lo..hi]);
                let mut at = starts;
                for (k, ray) in spare.iter().enumerate() {
                    let e = exits[lo + k] as usize;
                    rays[at[e]] = *ray;
                    at[e] += 1;
                }
                // An uncertain exit: the ray takes this step alone.
                self.finish_rays(query, run, &rays[starts[3]..hi], &packet, out);
                for r in (0..3).filter(|&r| counts[r] > 0) {
                    let mut beyond = packet;
                    beyond.advance(&self.setup, (d, pd), r as u8);
                    count_packet_step();
                    stack.push((starts[r], starts[r] + counts[r], beyond));
                }
                break;
            }
        }
    }

    /// Finishes each of `rays` (indices into `run`) with its own walk from where `packet`
    /// stands.
    fn finish_rays<K: QueryKind, S: Sink<K::Answer>>(
        &self,
        query: &K,
        run: &mut Run<R, M, K::Policy, O>,
        rays: &[PacketRay],
        packet: &Packet,
        out: &mut S,
    ) {
        let face = [packet.a, packet.b, packet.c];
        let state = |prepared: &M::Ray| {
            WalkState::plain::<R, L, M>(
                &self.setup,
                prepared,
                face,
                packet.link,
                packet.t,
                packet.steps,
            )
        };
        for i in rays.iter().map(|r| r.index) {
            if i & ENTERING != 0 {
                let (j, start) = run.entering[(i & !ENTERING) as usize];
                let mesh = self.locators.mesh;
                let prepared = match &run.prepared {
                    Some(like) => M::redirect(like, start.dir, &mesh.bounds),
                    None => M::prepare(start.o, start.dir, &mesh.bounds),
                };
                let observer = O::for_ray(start.point, start.dir, &mesh.bounds);
                let (policy, state) = (query.policy(&start), state(&prepared));
                let answer = self.walk_on(query, &start, &prepared, policy, observer, state);
                out.put(j, answer);
            } else {
                let (j, mut w) = run.started[i as usize].take().expect("a walking ray");
                w.state = state(&w.prepared);
                out.put(j, self.finish(query, w));
            }
        }
    }
}

/// Where a direction lies on a Morton curve over the cube's faces: the face (major axis and
/// its sign) in the top bits, then the other two coordinates over the major one, 14 bits
/// each, interleaved. Nearby directions get nearby keys (mostly).
pub(crate) fn direction_key(d: [f64; 3]) -> u32 {
    // Plain comparisons (a key only orders rays: ties and NaN may go anywhere).
    let a = d.map(f64::abs);
    let major = if a[0] >= a[1] && a[0] >= a[2] {
        0
    } else if a[1] >= a[2] {
        1
    } else {
        2
    };
    let (u, v) = (d[(major + 1) % 3], d[(major + 2) % 3]);
    let scale = 1.0 / a[major];
    // u/|d_major| and v/|d_major| lie in [-1, 1] (NaN and zero directions land anywhere).
    let quantize = |x: f64| (((x * scale).clamp(-1.0, 1.0) + 1.0) * 8191.5) as u32;
    let spread = |x: u32| {
        let mut x = x & 0x3fff;
        x = (x | x << 8) & 0x00ff_00ff;
        x = (x | x << 4) & 0x0f0f_0f0f;
        x = (x | x << 2) & 0x3333_3333;
        (x | x << 1) & 0x5555_5555
    };
    let face = (major as u32) << 1 | (d[major] < 0.0) as u32;
    face << 28 | spread(quantize(u)) << 1 | spread(quantize(v))
}
