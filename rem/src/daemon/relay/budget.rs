//! Byte budgets for the relay's queues: a queue may hold items only while it holds a
//! reservation for their bytes, from its own budget and from the daemon's. Waiting for room
//! is back-pressure (attached processes, links); trying and failing is a drop (a mailbox whose
//! process has not attached).

use std::sync::Arc;

use tokio::sync::{OwnedSemaphorePermit, Semaphore};

/// A number of bytes that may be reserved at once.
#[derive(Clone, Debug)]
pub struct ByteBudget {
    sem: Arc<Semaphore>,
    capacity: usize,
}

/// Bytes held in one or more budgets; given back when dropped.
#[derive(Debug, Default)]
pub struct Reservation {
    _permits: Vec<OwnedSemaphorePermit>,
}

impl ByteBudget {
    /// A budget of `bytes` (at least 1, at most what a semaphore can count).
    pub fn new(bytes: usize) -> Self {
        let capacity = bytes.clamp(1, Semaphore::MAX_PERMITS.min(u32::MAX as usize));
        ByteBudget {
            sem: Arc::new(Semaphore::new(capacity)),
            capacity,
        }
    }

    /// What one item of `bytes` costs here: never more than the whole budget, so a single
    /// item larger than the budget can still pass when the queue is empty.
    fn permits(&self, bytes: usize) -> u32 {
        bytes.clamp(1, self.capacity) as u32
    }

    /// Bytes free now.
    #[cfg(test)]
    pub fn available(&self) -> usize {
        self.sem.available_permits()
    }

    /// Reserves `bytes` in every budget of `budgets`, waiting for room in each in turn.
    pub async fn reserve(budgets: &[&ByteBudget], bytes: usize) -> Reservation {
        let mut permits = Vec::with_capacity(budgets.len());
        for b in budgets {
            match b.sem.clone().acquire_many_owned(b.permits(bytes)).await {
                Ok(p) => permits.push(p),
                Err(_) => break, // never closed
            }
        }
        Reservation { _permits: permits }
    }

    /// Reserves `bytes` in every budget of `budgets` now, or nothing at all.
    pub fn try_reserve(budgets: &[&ByteBudget], bytes: usize) -> Option<Reservation> {
        let mut permits = Vec::with_capacity(budgets.len());
        for b in budgets {
            permits.push(
                b.sem
                    .clone()
                    .try_acquire_many_owned(b.permits(bytes))
                    .ok()?,
            );
        }
        Some(Reservation { _permits: permits })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[tokio::test]
    async fn reservations_hold_bytes_until_dropped() {
        let own = ByteBudget::new(100);
        let all = ByteBudget::new(150);
        let a = ByteBudget::try_reserve(&[&own, &all], 60).unwrap();
        assert!(ByteBudget::try_reserve(&[&own, &all], 60).is_none());
        // A failed try leaves nothing held.
        assert_eq!((own.available(), all.available()), (40, 90));
        let other = ByteBudget::new(100);
        let b = ByteBudget::try_reserve(&[&other, &all], 90).unwrap();
        assert_eq!(all.available(), 0);
        drop(a);
        assert_eq!((own.available(), all.available()), (100, 60));
        drop(b);
        // An item larger than a budget costs the whole budget, and passes alone.
        let big = ByteBudget::reserve(&[&own], 1000).await;
        assert_eq!(own.available(), 0);
        drop(big);
        assert_eq!(own.available(), 100);
    }
}
