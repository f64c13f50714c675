//! When a view's estimate starts again, and what each iteration does with the history of its
//! pixels (`RppmHistory`): the bookkeeping alone, without GPU resources, unit-tested.

bitflags::bitflags! {
    /// What accumulation does with a pixel's history this iteration (`history_flags` of the
    /// iteration's params).
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
    pub struct HistoryFlags: u32 {
        /// The camera moved: fetch the history where the pixel's surface was last frame.
        const REPROJECT = 1;
        /// The first iteration after a change: drop history whose surface is not this one.
        const CHECK_SURFACE = 2;
        /// A scene change is settling: history is clamped to what the pixel's neighbourhood
        /// sees this iteration (the cap to the window comes with any change).
        const CHECK_LIGHT = 4;
        /// The scene changed: direct light, traced anew each iteration with little noise,
        /// starts again (shadows and highlights follow at once). A camera move keeps it.
        const NEW_DIRECT = 8;
        /// ... and its light may have changed. Without it only objects moved: still
        /// surfaces' direct light changes only where shadows move, and is clamped to its
        /// neighbourhood instead of starting again.
        const RELIT = 16;
    }
}

impl HistoryFlags {
    /// The iteration clamps history to its pixels' neighbourhoods (the accumulate shader's
    /// `clamping`), reading each neighbour's mean since the change from last iteration's copy.
    pub fn clamps(self) -> bool {
        self.intersects(Self::CHECK_LIGHT | Self::REPROJECT)
    }
}

/// What changed since a view's last frame.
#[derive(Clone, Copy, Debug, Default)]
pub struct Changes {
    /// Its settings or target size: always a new start.
    pub cut: bool,
    /// Its transform or projection.
    pub moved: bool,
    /// Anything in the scene.
    pub scene: bool,
    /// Its lights, emitters, materials or sky (with `scene`).
    pub relit: bool,
}

/// A view's iteration counters through resets and motion.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HistoryClock {
    /// Iterations since the estimate last started again (seeds and jitter never repeat
    /// within it; the stats' count).
    pub iteration: u32,
    /// Iterations run since the estimate started, or since the last change under `Reuse`
    /// (then 0 again): what `max_iterations` counts.
    pub held: u32,
    /// The history a change under `Reuse` kept (its window; 0 after a restart): the radius
    /// goes on from those iterations' instead of blurring every frame of a moving scene.
    kept: u32,
    /// Iterations left in which a change settles: each pixel's history is capped to the
    /// window.
    settling: u32,
    /// Iterations left in which a scene change settles: each pixel's history is also clamped
    /// to what its neighbourhood sees (a camera move alone does not change the light).
    light_settling: u32,
    /// The next iteration checks each pixel's surface, reprojecting when the camera moved.
    check_surface: bool,
    reproject: bool,
    new_direct: bool,
    relit: bool,
}

impl HistoryClock {
    /// Takes in this frame's changes under `window` (`None`: `RppmHistory::Reset`); returns
    /// whether the estimate starts again (every change without a window, a cut with one).
    pub fn begin_frame(&mut self, changes: Changes, window: Option<u32>) -> bool {
        let changed = changes.moved || changes.scene;
        match window {
            _ if changes.cut => self.restart(),
            None if changed => self.restart(),
            Some(window) if changed && self.iteration > 0 => {
                self.held = 0;
                self.kept = window;
                // Old light fades (a scene change), and a reprojected history does not blur
                // without end (a camera move).
                self.settling = window;
                if changes.scene {
                    self.light_settling = window;
                }
                self.check_surface = true;
                self.reproject |= changes.moved;
                self.new_direct |= changes.scene;
                self.relit |= changes.scene && changes.relit;
                false
            }
            _ => self.iteration == 0,
        }
    }

    fn restart(&mut self) -> bool {
        *self = Self::default();
        true
    }

    /// Jumps to iteration `n` as if that many had been held.
    pub fn fast_forward(&mut self, n: u32) {
        self.iteration = n;
        self.held = n;
        self.kept = 0;
    }

    /// The index of the Knaus–Zwicker radius of the next iteration.
    pub fn radius_index(&self) -> u32 {
        self.held + self.kept
    }

    /// The history cap and flags of the next iteration.
    pub fn next(&self, window: Option<u32>) -> (u32, HistoryFlags) {
        let mut flags = HistoryFlags::empty();
        flags.set(HistoryFlags::CHECK_SURFACE, self.check_surface);
        flags.set(
            HistoryFlags::REPROJECT,
            self.check_surface && self.reproject,
        );
        flags.set(HistoryFlags::CHECK_LIGHT, self.light_settling > 0);
        flags.set(HistoryFlags::NEW_DIRECT, self.new_direct);
        flags.set(HistoryFlags::RELIT, self.relit);
        let cap = match window {
            Some(window) if self.settling > 0 => window,
            _ => u32::MAX,
        };
        (cap, flags)
    }

    /// Counts one iteration run.
    pub fn advance(&mut self) {
        self.iteration += 1;
        self.held += 1;
        self.settling = self.settling.saturating_sub(1);
        self.light_settling = self.light_settling.saturating_sub(1);
        self.check_surface = false;
        self.reproject = false;
        self.new_direct = false;
        self.relit = false;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MOVED: Changes = Changes {
        cut: false,
        moved: true,
        scene: false,
        relit: false,
    };

    /// Something in the scene moved; its light did not change.
    const SCENE: Changes = Changes {
        cut: false,
        moved: false,
        scene: true,
        relit: false,
    };

    fn run(clock: &mut HistoryClock, n: u32) {
        for _ in 0..n {
            clock.advance();
        }
    }

    #[test]
    fn reset_starts_again_on_every_change() {
        let mut clock = HistoryClock::default();
        assert!(clock.begin_frame(Changes::default(), None));
        run(&mut clock, 10);
        assert!(!clock.begin_frame(Changes::default(), None));
        assert!(clock.begin_frame(MOVED, None));
        assert_eq!(clock, HistoryClock::default());
        assert_eq!(clock.next(None), (u32::MAX, HistoryFlags::empty()));
    }

    #[test]
    fn reuse_caps_the_history_while_a_change_settles() {
        let mut clock = HistoryClock::default();
        run(&mut clock, 20);
        assert!(!clock.begin_frame(SCENE, Some(8)));
        assert_eq!((clock.iteration, clock.held), (20, 0));
        assert_eq!(clock.radius_index(), 8);
        assert_eq!(
            clock.next(Some(8)),
            (
                8,
                HistoryFlags::CHECK_SURFACE | HistoryFlags::CHECK_LIGHT | HistoryFlags::NEW_DIRECT
            )
        );
        clock.advance();
        assert_eq!(clock.next(Some(8)), (8, HistoryFlags::CHECK_LIGHT));
        run(&mut clock, 7);
        // Settled: the estimate grows again as a still scene's does.
        assert_eq!(clock.next(Some(8)), (u32::MAX, HistoryFlags::empty()));
        assert_eq!((clock.iteration, clock.held), (28, 8));
        assert_eq!(clock.radius_index(), 16);
    }

    #[test]
    fn a_settling_change_clamps_and_a_still_estimate_does_not() {
        let mut clock = HistoryClock::default();
        run(&mut clock, 10);
        assert!(!clock.next(Some(8)).1.clamps());
        assert!(!clock.begin_frame(SCENE, Some(8)));
        assert!(clock.next(Some(8)).1.clamps());
        run(&mut clock, 8);
        assert!(!clock.next(Some(8)).1.clamps());
        assert!(!clock.begin_frame(MOVED, Some(8)));
        assert!(clock.next(Some(8)).1.clamps());
    }

    #[test]
    fn a_light_change_restarts_direct_light_everywhere_a_moved_object_only_its_own() {
        let mut clock = HistoryClock::default();
        run(&mut clock, 4);
        assert!(!clock.begin_frame(SCENE, Some(8)));
        assert!(!clock.next(Some(8)).1.contains(HistoryFlags::RELIT));
        clock.advance();
        let relit = Changes {
            relit: true,
            ..SCENE
        };
        assert!(!clock.begin_frame(relit, Some(8)));
        let flags = clock.next(Some(8)).1;
        assert!(flags.contains(HistoryFlags::NEW_DIRECT | HistoryFlags::RELIT));
        clock.advance();
        assert!(
            !clock
                .next(Some(8))
                .1
                .intersects(HistoryFlags::NEW_DIRECT | HistoryFlags::RELIT)
        );
    }

    #[test]
    fn a_camera_move_reprojects_once_and_a_cut_restarts() {
        let mut clock = HistoryClock::default();
        run(&mut clock, 5);
        assert!(!clock.begin_frame(MOVED, Some(16)));
        let (cap, flags) = clock.next(Some(16));
        assert!(flags.contains(HistoryFlags::REPROJECT | HistoryFlags::CHECK_SURFACE));
        // A camera move keeps direct light (a diffuse surface's does not change with the view).
        assert!(!flags.intersects(HistoryFlags::NEW_DIRECT | HistoryFlags::CHECK_LIGHT));
        assert_eq!((cap, clock.held), (16, 0));
        clock.advance();
        assert!(!clock.next(Some(16)).1.contains(HistoryFlags::REPROJECT));
        let cut = Changes {
            cut: true,
            moved: true,
            ..Changes::default()
        };
        assert!(clock.begin_frame(cut, Some(16)));
        assert_eq!(clock.iteration, 0);
    }
}
