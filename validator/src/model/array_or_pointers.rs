//! Members the API gives either as an array or as an array of pointers to
//! elements (`pGeometries` or `ppGeometries`, `pUsageCounts` or
//! `ppUsageCounts`), and the one walk over them the checks share.

/// A count with the array and the array of pointers it counts, as the
/// model holds them: None where a pointer is NULL, and a None element for a
/// NULL element of the pointers.
pub type CountedElements<T> = (u32, Option<Vec<T>>, Option<Vec<Option<T>>>);

/// The elements a structure's array-or-pointers member is read from, with
/// their indices: the elements of the array, or, where the array is not
/// set, the non-NULL elements of the pointer array (a NULL pointer is
/// skipped, its index is kept). A plain iterator over two slices, one of
/// them empty: cheaper per step than chained adapters, and the checks walk
/// it once per rule on every call.
#[derive(Clone, Debug)]
pub struct ElementsRead<'a, T> {
    array: std::slice::Iter<'a, T>,
    pointers: std::slice::Iter<'a, Option<T>>,
    index: usize,
}

impl<'a, T> ElementsRead<'a, T> {
    /// The walk over `array`, or over `pointers` where `array` is None (the
    /// pointer array is read only when the array is not set).
    pub fn new(array: Option<&'a [T]>, pointers: Option<&'a [Option<T>]>) -> Self {
        let pointers = pointers.filter(|_| array.is_none());
        Self {
            array: array.unwrap_or_default().iter(),
            pointers: pointers.unwrap_or_default().iter(),
            index: 0,
        }
    }
}

impl<'a, T> Iterator for ElementsRead<'a, T> {
    type Item = (usize, &'a T);

    fn next(&mut self) -> Option<Self::Item> {
        loop {
            let index = self.index;
            let element = match self.array.next() {
                Some(element) => Some(element),
                None => self.pointers.next()?.as_ref(),
            };
            self.index += 1;
            if let Some(element) = element {
                return Some((index, element));
            }
        }
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        (
            self.array.len(),
            self.array.len().checked_add(self.pointers.len()),
        )
    }
}

/// [`ElementsRead`] over elements that are plain values, yielding copies
/// (as `Iterator::copied`, with the index kept).
#[derive(Clone, Debug)]
pub struct ElementsCopied<'a, T>(ElementsRead<'a, T>);

impl<'a, T: Copy> ElementsRead<'a, T> {
    /// The same walk, yielding copies of the elements.
    pub fn copied(self) -> ElementsCopied<'a, T> {
        ElementsCopied(self)
    }
}

impl<T: Copy> Iterator for ElementsCopied<'_, T> {
    type Item = (usize, T);

    fn next(&mut self) -> Option<Self::Item> {
        self.0.next().map(|(index, element)| (index, *element))
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        self.0.size_hint()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_array_wins_and_null_pointers_keep_their_index() {
        let pointers = [Some(1), None, Some(3)];
        let read: Vec<_> = ElementsRead::new(None, Some(&pointers[..])).collect();
        assert_eq!(read, [(0, &1), (2, &3)]);
        let read: Vec<_> = ElementsRead::new(Some(&[5][..]), Some(&pointers[..])).collect();
        assert_eq!(read, [(0, &5)]);
        assert_eq!(ElementsRead::<u8>::new(None, None).count(), 0);
        let copied: Vec<_> = ElementsRead::new(None, Some(&pointers[..]))
            .copied()
            .collect();
        assert_eq!(copied, [(0, 1), (2, 3)]);
    }
}
