//! Cooperative cancellation: a deadline and a flag that long-running work checks.
//!
//! The fitters and solvers check a [`Cancel`] every iteration (each iteration is one pass over
//! the data, or a bounded local refit), so once the time budget has run out or the owner has
//! called [`Cancel::cancel`], the work stops within about one iteration and returns
//! [`SphereError::Cancelled`]. Nothing here knows why work is cancelled (an HTTP request's
//! budget, a client that went away, a CLI deadline): it is a plain deadline and a flag.
//!
//! Deep loops that do not see an options struct check the cancel of the current thread
//! ([`cancelled`]), set by [`Cancel::enter`] for the duration of an entry point. The default
//! token *inherits*: it is cancelled when the token entered on the current thread is (and
//! never when none is), so a caller higher up (the Earth layer, a service) can bound work whose
//! options it does not build. Work that fans out to other threads (rayon) enters the token
//! again on each thread it uses.
//!
//! ```
//! use spherefit::sphere::cancel::Cancel;
//! use std::time::{Duration, Instant};
//! let c = Cancel::with_deadline(Instant::now() + Duration::from_secs(60));
//! assert!(!c.is_cancelled());
//! c.cancel();
//! assert!(c.is_cancelled());
//! assert!(!Cancel::inherit().is_cancelled());
//! let scope = c.enter();
//! assert!(Cancel::inherit().is_cancelled());
//! drop(scope);
//! assert!(!Cancel::inherit().is_cancelled());
//! ```

use crate::sphere::SphereError;
use std::cell::RefCell;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// A cancellation token: a flag, and optionally a deadline after which it counts as set.
/// Clones share the flag. The default ([`Cancel::inherit`]) defers to the token entered on the
/// current thread.
#[derive(Clone, Debug, Default)]
pub struct Cancel(Option<Arc<Inner>>);

#[derive(Debug)]
struct Inner {
    flag: AtomicBool,
    deadline: Option<Instant>,
}

impl Cancel {
    /// The token entered on the current thread when checked ([`Cancel::enter`]); none entered:
    /// never cancelled.
    pub fn inherit() -> Cancel {
        Cancel(None)
    }

    /// A token cancelled only by [`Cancel::cancel`].
    pub fn new() -> Cancel {
        Cancel(Some(Arc::new(Inner {
            flag: AtomicBool::new(false),
            deadline: None,
        })))
    }

    /// A token cancelled by [`Cancel::cancel`] or once `deadline` has passed.
    pub fn with_deadline(deadline: Instant) -> Cancel {
        Cancel(Some(Arc::new(Inner {
            flag: AtomicBool::new(false),
            deadline: Some(deadline),
        })))
    }

    /// Cancels the work holding this token (and every clone of it).
    pub fn cancel(&self) {
        if let Some(i) = &self.0 {
            i.flag.store(true, Ordering::Relaxed);
        }
    }

    /// Whether the work should stop: cancelled, or past the deadline (for an inheriting token:
    /// whether the current thread's token is).
    pub fn is_cancelled(&self) -> bool {
        let Some(i) = &self.0 else {
            return cancelled();
        };
        if i.flag.load(Ordering::Relaxed) {
            return true;
        }
        if i.deadline.is_some_and(|d| Instant::now() >= d) {
            i.flag.store(true, Ordering::Relaxed);
            return true;
        }
        false
    }

    /// `Err(SphereError::Cancelled)` when [`Cancel::is_cancelled`].
    ///
    /// # Errors
    /// [`SphereError::Cancelled`].
    pub fn check(&self) -> Result<(), SphereError> {
        if self.is_cancelled() {
            Err(SphereError::Cancelled)
        } else {
            Ok(())
        }
    }

    /// Makes this the token [`cancelled`] checks on this thread until the returned scope is
    /// dropped (scopes nest: the previous token comes back). Entering an inheriting token
    /// changes nothing.
    pub fn enter(&self) -> Scope {
        if self.0.is_none() {
            return Scope { previous: None };
        }
        let previous = CURRENT.with(|c| c.replace(self.clone()));
        Scope {
            previous: Some(previous),
        }
    }
}

/// Tokens are equal when they are the same token (or both inherit): options structs that hold
/// one still compare by what they compute.
impl PartialEq for Cancel {
    fn eq(&self, other: &Cancel) -> bool {
        match (&self.0, &other.0) {
            (None, None) => true,
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            _ => false,
        }
    }
}

thread_local! {
    static CURRENT: RefCell<Cancel> = const { RefCell::new(Cancel(None)) };
}

/// The scope of [`Cancel::enter`].
#[must_use = "the token is current only while the scope lives"]
pub struct Scope {
    previous: Option<Cancel>,
}

impl Drop for Scope {
    fn drop(&mut self) {
        if let Some(previous) = self.previous.take() {
            CURRENT.with(|c| *c.borrow_mut() = previous);
        }
    }
}

/// The token entered on the current thread ([`Cancel::enter`]), to hand to worker threads
/// (rayon's threads do not see the caller's scope); an inheriting token when none is.
pub fn current() -> Cancel {
    CURRENT.with(|c| c.borrow().clone())
}

/// Whether the token entered on the current thread ([`Cancel::enter`]) is cancelled.
pub fn cancelled() -> bool {
    CURRENT.with(|c| {
        let c = c.borrow();
        c.0.is_some() && c.is_cancelled()
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::Duration;

    #[test]
    fn a_past_deadline_cancels() {
        let c = Cancel::with_deadline(Instant::now() - Duration::from_millis(1));
        assert!(c.is_cancelled());
        assert_eq!(c.check(), Err(SphereError::Cancelled));
        let later = Cancel::with_deadline(Instant::now() + Duration::from_secs(3600));
        assert!(later.check().is_ok());
    }

    #[test]
    fn clones_share_the_flag_and_scopes_nest() {
        let c = Cancel::new();
        let d = c.clone();
        assert_eq!(c, d);
        assert_ne!(c, Cancel::new());
        assert!(!cancelled());
        {
            let _s = c.enter();
            assert!(!cancelled());
            d.cancel();
            assert!(cancelled());
            {
                let _inner = Cancel::inherit().enter();
                assert!(cancelled());
                assert!(Cancel::inherit().is_cancelled());
                let _other = Cancel::new().enter();
                assert!(!cancelled());
            }
            assert!(cancelled());
        }
        assert!(!cancelled());
    }
}
