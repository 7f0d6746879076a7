//! Giving up objects whose model stops improving, so that a session ends when nothing more can be
//! learnt instead of at the time limit.
//!
//! # The stall rule (`[planner.give_up]`)
//! After every GBV round of VP-SOM aimed at a cluster (its goal reached or refused), the H_sopm of
//! each unfinished foreground object of that cluster is sampled, provided the object was observed
//! during the round (its `observations` count grew): rounds that did not see an object say
//! nothing about whether it can be improved. An object is **given up** once, over its last
//! `rounds` such samples, its H_sopm fell by less than `min_drop` below the value before them
//! (`h[k−N] − min(h[k−N+1..=k]) < δ`). That is the case for a side no reachable view sees
//! (a box against a wall: its back cells stay at p = 0.5 however often its front is seen).
//! An object whose H_sopm still falls by δ every N rounds is left to the cluster's
//! `gbv.max_rounds_per_cluster` rule, which ends the cluster and gives up what is left of it.
//!
//! Given-up objects count as finished for termination ([`GiveUps::settled`]); the session
//! reports them ([`GivenUpObject`]).
//!
//! # Untrusted objects (`planner.min_observations`)
//! A map object with fewer associated detections than `min_observations` is not trusted yet
//! (detector false positives last one or two frames): an untrusted foreground object is neither
//! open nor given up, and a cluster whose background object is untrusted is settled, so neither
//! opens a cluster or holds the session open. Once trusted, it counts like any other.

use crate::clusters::{ClusterInfo, fg_done, members};
use shm_types::{ObjectMap, class_name};

/// Parameters of the stall rule.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StallRule {
    /// Rounds (N) over which the H_sopm must fall.
    pub rounds: usize,
    /// Least fall (δ) of H_sopm over `rounds` rounds.
    pub min_drop: f32,
}

impl StallRule {
    /// Whether the history (oldest first) has stalled.
    pub fn stalled(&self, h: &[f32]) -> bool {
        let n = self.rounds.max(1);
        if h.len() < n + 1 {
            return false;
        }
        let before = h[h.len() - 1 - n];
        let best = h[h.len() - n..]
            .iter()
            .copied()
            .fold(f32::INFINITY, f32::min);
        before - best < self.min_drop
    }
}

/// Why an object was given up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GiveUpCause {
    /// Its H_sopm stopped falling (the stall rule).
    Stalled,
    /// Its cluster used up its GBV rounds, or had no new view left.
    ClusterEnded,
}

impl GiveUpCause {
    /// Short name for reports.
    pub fn name(self) -> &'static str {
        match self {
            GiveUpCause::Stalled => "entropy stalled",
            GiveUpCause::ClusterEnded => "cluster out of views",
        }
    }
}

/// A foreground object the planner gave up.
#[derive(Debug, Clone, PartialEq)]
pub struct GivenUpObject {
    /// Map object id.
    pub map_id: u32,
    /// Its cluster.
    pub cluster_id: i32,
    /// COCO class name.
    pub label: &'static str,
    /// H_sopm when it was given up.
    pub h_sopm: f32,
    /// Why.
    pub cause: GiveUpCause,
}

#[derive(Debug, Clone)]
struct Track {
    id: u32,
    observations: u32,
    h: Vec<f32>,
}

/// The objects given up so far, and the H_sopm histories the stall rule reads.
#[derive(Debug, Clone)]
pub struct GiveUps {
    rule: StallRule,
    eps_sopm: f32,
    min_observations: u32,
    tracks: Vec<Track>,
    given_up: Vec<GivenUpObject>,
}

impl GiveUps {
    /// An empty record; objects with fewer than `min_observations` detections are untrusted.
    pub fn new(rule: StallRule, eps_sopm: f32, min_observations: u32) -> Self {
        Self {
            rule,
            eps_sopm,
            min_observations,
            tracks: Vec::new(),
            given_up: Vec::with_capacity(shm_types::MAX_OBJECTS),
        }
    }

    /// Whether object `id` was given up.
    pub fn contains(&self, id: u32) -> bool {
        self.given_up.iter().any(|g| g.map_id == id)
    }

    /// The objects given up, in order.
    pub fn list(&self) -> &[GivenUpObject] {
        &self.given_up
    }

    /// Whether the object has enough detections to be trusted.
    pub fn trusted(&self, o: &shm_types::MapObject) -> bool {
        o.observations >= self.min_observations
    }

    /// Whether a foreground object still needs views: trusted, not done, not given up.
    pub fn is_open(&self, o: &shm_types::MapObject) -> bool {
        !o.is_background() && self.trusted(o) && !fg_done(o, self.eps_sopm) && !self.contains(o.id)
    }

    /// The open foreground objects of cluster `cluster` (see [`GiveUps::is_open`]).
    pub fn open_members<'a>(
        &'a self,
        map: &'a ObjectMap,
        cluster: i32,
    ) -> impl Iterator<Item = &'a shm_types::MapObject> + 'a {
        members(map, cluster).filter(move |o| self.is_open(o))
    }

    fn give_up(&mut self, o: &shm_types::MapObject, cause: GiveUpCause) {
        self.given_up.push(GivenUpObject {
            map_id: o.id,
            cluster_id: o.cluster_id,
            label: class_name(o.class_id),
            h_sopm: o.h_sopm,
            cause,
        });
    }

    /// Start the histories of cluster `cluster`'s unfinished objects (before its first round).
    pub fn start(&mut self, map: &ObjectMap, cluster: i32) {
        let fresh: Vec<(u32, u32, f32)> = self
            .open_members(map, cluster)
            .filter(|o| !self.tracks.iter().any(|t| t.id == o.id))
            .map(|o| (o.id, o.observations, o.h_sopm))
            .collect();
        for (id, observations, h) in fresh {
            self.tracks.push(Track {
                id,
                observations,
                h: vec![h],
            });
        }
    }

    /// A GBV round aimed at `cluster` ended: sample its unfinished objects that were observed
    /// during the round and give up those that stalled. Returns how many were given up.
    pub fn round_ended(&mut self, map: &ObjectMap, cluster: i32) -> usize {
        let objs: Vec<shm_types::MapObject> = self.open_members(map, cluster).copied().collect();
        let mut n = 0;
        for o in &objs {
            let rule = self.rule;
            let stalled = match self.tracks.iter_mut().find(|t| t.id == o.id) {
                None => {
                    self.tracks.push(Track {
                        id: o.id,
                        observations: o.observations,
                        h: vec![o.h_sopm],
                    });
                    false
                }
                Some(t) if o.observations > t.observations => {
                    t.observations = o.observations;
                    t.h.push(o.h_sopm);
                    rule.stalled(&t.h)
                }
                Some(_) => false,
            };
            if stalled {
                self.give_up(o, GiveUpCause::Stalled);
                n += 1;
            }
        }
        n
    }

    /// Cluster `cluster` ended (out of rounds or views): give up its unfinished objects.
    pub fn cluster_ended(&mut self, map: &ObjectMap, cluster: i32) -> usize {
        let objs: Vec<shm_types::MapObject> = self.open_members(map, cluster).copied().collect();
        for o in &objs {
            self.give_up(o, GiveUpCause::ClusterEnded);
        }
        objs.len()
    }

    /// Whether cluster `info` needs no more views: done, its background object untrusted, or
    /// approached with no foreground object of it open (a cluster without foreground objects
    /// follows `info.done`). Does not allocate.
    pub fn settled(&self, map: &ObjectMap, info: &ClusterInfo) -> bool {
        info.done
            || members(map, info.id).any(|o| o.is_background() && !self.trusted(o))
            || info.foreground > 0
                && info.approached
                && self.open_members(map, info.id).next().is_none()
    }

    /// Mark every given-up or untrusted foreground object of `map` complete (for a planning
    /// job's snapshot, so that the target centroid and completion rules skip them).
    pub fn mark_complete(&self, map: &mut ObjectMap) {
        let n = map.count as usize;
        for o in map.objects[..n].iter_mut() {
            if self.contains(o.id) || !o.is_background() && !self.trusted(o) {
                o.complete = 1;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shm_types::boxed_zeroed;

    fn rule() -> StallRule {
        StallRule {
            rounds: 3,
            min_drop: 0.02,
        }
    }

    #[test]
    fn stall_rule_needs_n_rounds_without_a_fall_of_delta() {
        let r = rule();
        assert!(!r.stalled(&[0.9, 0.9, 0.9]), "too few rounds");
        assert!(r.stalled(&[0.9, 0.9, 0.895, 0.89]));
        assert!(
            r.stalled(&[0.6, 0.62, 0.61, 0.7]),
            "rising counts as no fall"
        );
        assert!(
            !r.stalled(&[0.9, 0.9, 0.9, 0.85]),
            "the last round fell by 0.05"
        );
        assert!(
            !r.stalled(&[0.9, 0.8, 0.81, 0.82]),
            "the best of the window counts"
        );
        assert!(
            r.stalled(&[1.0, 0.5, 0.495, 0.49, 0.49]),
            "only the last N count"
        );
    }

    fn map_with(h: f32, observations: u32) -> Box<ObjectMap> {
        let mut m = boxed_zeroed::<ObjectMap>();
        m.count = 2;
        m.objects[0].id = 1;
        m.objects[0].background = 1;
        m.objects[0].cluster_id = 1;
        m.objects[0].observations = 5;
        m.objects[1].id = 7;
        m.objects[1].cluster_id = 1;
        m.objects[1].class_id = 39; // bottle
        m.objects[1].h_sopm = h;
        m.objects[1].observations = observations;
        m
    }

    #[test]
    fn an_object_seen_without_progress_is_given_up_and_settles_its_cluster() {
        let mut g = GiveUps::new(rule(), 0.42, 1);
        let m = map_with(0.6, 1);
        g.start(&m, 1);
        let mut info = crate::clusters::cluster_info(&m, 1, 0.42).unwrap();
        info.approached = true;
        assert!(!g.settled(&m, &info));
        // Rounds that did not observe it do not count.
        for _ in 0..5 {
            assert_eq!(g.round_ended(&m, 1), 0);
        }
        // Rounds that observe it with falling entropy keep it.
        let mut obs = 1;
        for h in [0.55, 0.5, 0.45] {
            obs += 10;
            assert_eq!(g.round_ended(&map_with(h, obs), 1), 0);
        }
        // Three observed rounds at ≈ 0.45: given up.
        let mut given = 0;
        for h in [0.449, 0.448, 0.447] {
            obs += 10;
            given += g.round_ended(&map_with(h, obs), 1);
        }
        assert_eq!(given, 1);
        let last = map_with(0.447, obs);
        assert!(g.contains(7) && g.settled(&last, &info));
        let e = &g.list()[0];
        assert_eq!(
            (e.map_id, e.label, e.cause),
            (7, "bottle", GiveUpCause::Stalled)
        );
        assert!((e.h_sopm - 0.447).abs() < 1e-6);
        let mut snap = map_with(0.447, obs);
        g.mark_complete(&mut snap);
        assert!(snap.objects[1].is_complete());
        // A done object is never given up.
        let mut g2 = GiveUps::new(rule(), 0.42, 1);
        assert_eq!(g2.cluster_ended(&map_with(0.3, 1), 1), 0);
        assert_eq!(g2.cluster_ended(&map_with(0.5, 1), 1), 1);
    }
}
