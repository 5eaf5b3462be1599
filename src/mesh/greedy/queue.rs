//! The mesher's queue: an indexed binary max-heap of triangles by scan key, with removal (a
//! triangle replaced by a flip or split leaves the queue wherever it is).

use super::Mesher;

impl Mesher<'_> {
    pub(super) fn less(&self, i: usize, j: usize) -> bool {
        self.scans[self.queue[i] as usize].key > self.scans[self.queue[j] as usize].key
    }

    pub(super) fn swap(&mut self, i: usize, j: usize) {
        self.queue.swap(i, j);
        self.qpos[self.queue[i] as usize] = i as i32;
        self.qpos[self.queue[j] as usize] = j as i32;
    }

    pub(super) fn up(&mut self, mut j: usize) {
        while j > 0 {
            let i = (j - 1) / 2;
            if !self.less(j, i) {
                break;
            }
            self.swap(i, j);
            j = i;
        }
    }

    /// Sift down within `..n`; `true` when the element moved.
    pub(super) fn down(&mut self, i0: usize, n: usize) -> bool {
        let mut i = i0;
        loop {
            let j1 = 2 * i + 1;
            if j1 >= n {
                break;
            }
            let j = if j1 + 1 < n && self.less(j1 + 1, j1) { j1 + 1 } else { j1 };
            if !self.less(j, i) {
                break;
            }
            self.swap(i, j);
            i = j;
        }
        i > i0
    }

    pub(super) fn queue_push(&mut self, t: u32) {
        let i = self.queue.len();
        self.qpos[t as usize] = i as i32;
        self.queue.push(t);
        self.up(i);
    }

    pub(super) fn queue_pop(&mut self) -> u32 {
        let n = self.queue.len() - 1;
        self.swap(0, n);
        self.down(0, n);
        let t = self.queue.pop().expect("non-empty queue");
        self.qpos[t as usize] = -1;
        t
    }

    pub(super) fn queue_remove(&mut self, t: usize) {
        let i = self.qpos[t];
        if i < 0 {
            // Not scanned yet: drop it from the pending list.
            if let Some(k) = self.pending.iter().position(|&p| p as usize == t) {
                self.pending.swap_remove(k);
            }
            return;
        }
        let (i, n) = (i as usize, self.queue.len() - 1);
        if i != n {
            self.swap(i, n);
            if !self.down(i, n) {
                self.up(i);
            }
        }
        let t = self.queue.pop().expect("non-empty queue");
        self.qpos[t as usize] = -1;
    }
}
