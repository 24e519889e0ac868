//! `State::buffers_at` answers through an address index; these tests hold
//! it to the walk over every buffer it replaced, kept here as the
//! reference, across inserts, re-inserts, address and size changes and
//! destroys: overlapping ranges, shared starts, zero sizes, ranges that
//! saturate at the top of the address space, and addresses exactly at a
//! range's end. Lookups among few buffers walk them all; the tests add
//! filler buffers to take the index's path as well.

use ommcheck::state::{Buffer, State, WALK_AT_MOST};

use ommcheck::model::Handle;
use proptest::prelude::*;

/// The lookup as it was: every buffer, lowest handle first.
fn reference_buffers_at(state: &State, address: u64) -> Vec<Handle> {
    state
        .buffers
        .iter()
        .filter_map(|(handle, buffer)| {
            let (start, end) = buffer.address_range()?;
            (start <= address && address < end).then_some(*handle)
        })
        .collect()
}

fn reference_range_in_one_buffer(state: &State, address: u64, len: u64) -> bool {
    let Some(end) = address.checked_add(len) else {
        return false;
    };
    state.buffers.iter().any(|(_, buffer)| {
        buffer
            .address_range()
            .is_some_and(|(start, e)| start <= address && address < e && end <= e)
    })
}

fn indexed_buffers_at(state: &State, address: u64) -> Vec<Handle> {
    state
        .buffers_at(address)
        .map(|(handle, _)| handle)
        .collect()
}

/// Handles of filler buffers: above those the operations use.
const FILLER_HANDLE: Handle = 1_000;
/// Where filler buffers lie: away from the operations' addresses, save the
/// one filler that spans them all.
const FILLER_ADDRESS: u64 = 0x100_0000;

/// Enough buffers for lookups to go through the index rather than walk
/// them: address-less ones, neighbours 0x100 long, and one range over the
/// addresses the operations use.
fn add_fillers(state: &mut State) {
    for i in 0..=WALK_AT_MOST as u64 {
        let (device_address, size) = match i % 3 {
            0 => (None, 0x100),
            1 => (Some(FILLER_ADDRESS + i * 0x100), 0x100),
            _ => (Some(FILLER_ADDRESS + i * 0x100), 0x80),
        };
        state.buffers.insert(
            FILLER_HANDLE + i,
            Buffer {
                size,
                device_address,
                ..Default::default()
            },
        );
    }
    state.buffers.insert(
        FILLER_HANDLE + WALK_AT_MOST as u64 + 1,
        Buffer {
            size: 0x10_0000,
            device_address: Some(0xf00),
            ..Default::default()
        },
    );
}

/// Addresses worth asking about: every start, end and their neighbours
/// (of the fillers, only the first few), and the ends of the address space.
fn probe_addresses(state: &State) -> Vec<u64> {
    let mut probes = vec![0, 1, u64::MAX - 1, u64::MAX];
    let fillers_to_probe = FILLER_HANDLE..FILLER_HANDLE + 4;
    for (_, buffer) in state
        .buffers
        .iter()
        .filter(|(handle, _)| **handle < FILLER_HANDLE || fillers_to_probe.contains(handle))
    {
        if let Some((start, end)) = buffer.address_range() {
            for address in [start, end] {
                probes.extend([address.wrapping_sub(1), address, address.wrapping_add(1)]);
            }
        }
    }
    probes
}

fn assert_matches_reference(state: &State, extra: &[u64]) -> Result<(), TestCaseError> {
    let knows = state.buffers.values().any(|b| b.device_address.is_some());
    prop_assert_eq!(state.knows_addresses(), knows);
    for address in probe_addresses(state)
        .into_iter()
        .chain(extra.iter().copied())
    {
        prop_assert_eq!(
            indexed_buffers_at(state, address),
            reference_buffers_at(state, address),
            "buffers at {:#x}",
            address
        );
        for len in [0, 1, 7, 64, u64::MAX] {
            prop_assert_eq!(
                state.range_in_one_buffer(address, len),
                reference_range_in_one_buffer(state, address, len),
                "range {:#x} + {}",
                address,
                len
            );
        }
    }
    Ok(())
}

#[derive(Clone, Debug)]
enum Op {
    Create {
        handle: Handle,
        address: Option<u64>,
        size: u64,
    },
    Destroy(Handle),
    SetAddress(Handle, Option<u64>),
    SetSize(Handle, u64),
    /// A change through `get_mut` that leaves the address and size alone.
    SetUsage(Handle, u64),
}

/// Few handles and a narrow address window, so that buffers collide:
/// shared starts, nested and overlapping ranges, re-created handles.
fn handle() -> impl Strategy<Value = Handle> {
    1u64..24
}

fn address() -> impl Strategy<Value = Option<u64>> {
    prop_oneof![
        1 => Just(None),
        6 => (0u64..32).prop_map(|slot| Some(0x1000 + slot * 8)),
        1 => (0u64..16).prop_map(|back| Some(u64::MAX - back)),
        1 => Just(Some(0)),
    ]
}

fn size() -> impl Strategy<Value = u64> {
    prop_oneof![
        1 => Just(0),
        6 => 1u64..96,
        1 => (0u32..64).prop_map(|bits| 1u64 << bits),
        1 => Just(u64::MAX),
    ]
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        4 => (handle(), address(), size()).prop_map(|(handle, address, size)| Op::Create {
            handle,
            address,
            size
        }),
        2 => handle().prop_map(Op::Destroy),
        1 => (handle(), address()).prop_map(|(h, a)| Op::SetAddress(h, a)),
        1 => (handle(), size()).prop_map(|(h, s)| Op::SetSize(h, s)),
        1 => (handle(), any::<u64>()).prop_map(|(h, u)| Op::SetUsage(h, u)),
    ]
}

fn apply(state: &mut State, op: &Op) {
    match *op {
        Op::Create {
            handle,
            address,
            size,
        } => {
            state.buffers.insert(
                handle,
                Buffer {
                    size,
                    device_address: address,
                    ..Default::default()
                },
            );
        }
        Op::Destroy(handle) => {
            state.buffers.remove(&handle);
        }
        Op::SetAddress(handle, address) => {
            if let Some(mut buffer) = state.buffers.get_mut(&handle) {
                buffer.device_address = address;
            }
        }
        Op::SetSize(handle, size) => {
            if let Some(mut buffer) = state.buffers.get_mut(&handle) {
                buffer.size = size;
            }
        }
        Op::SetUsage(handle, usage) => {
            if let Some(mut buffer) = state.buffers.get_mut(&handle) {
                buffer.usage = usage;
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn lookups_match_the_walk_over_every_buffer(
        fillers in any::<bool>(),
        ops in prop::collection::vec(op(), 1..64),
        extra in prop::collection::vec(any::<u64>(), 0..4),
    ) {
        let mut state = State::default();
        if fillers {
            add_fillers(&mut state);
        }
        for op in &ops {
            apply(&mut state, op);
            assert_matches_reference(&state, &extra)?;
        }
    }
}

/// Ten thousand buffers, overlapping at every level: a row of small
/// neighbours, aliases sharing starts, a few long ranges spanning many
/// others, zero-sized and address-less ones; then a third destroyed.
#[test]
fn many_buffers_match_the_walk_over_every_buffer() {
    let mut state = State::default();
    let mut handle: Handle = 1;
    let mut add = |state: &mut State, address: Option<u64>, size: u64| {
        state.buffers.insert(
            handle,
            Buffer {
                size,
                device_address: address,
                ..Default::default()
            },
        );
        handle += 1;
    };
    for i in 0..6_000u64 {
        // Neighbours 0x100 apart, each 0x100 long: one ends where the next starts.
        add(&mut state, Some(0x10_0000 + i * 0x100), 0x100);
    }
    for i in 0..2_000u64 {
        // Aliases: two buffers at each of a thousand starts, of different lengths.
        add(
            &mut state,
            Some(0x10_0000 + (i / 2) * 0x300),
            0x80 << (i % 2),
        );
    }
    for i in 0..1_000u64 {
        // Long ranges, each over thousands of the small ones.
        add(&mut state, Some(0x10_0000 + i * 0x600), 0x40_0000 + i);
    }
    for i in 0..1_000u64 {
        add(&mut state, Some(0x10_0000 + i * 0x100), 0);
        add(&mut state, None, 0x100);
    }
    let count = state.buffers.len();
    assert_eq!(count, 11_000);

    let probes: Vec<u64> = (0..400u64)
        .flat_map(|i| {
            let base = 0x10_0000 + i * 0x1_1111;
            [
                base - 1,
                base,
                base + 0x7f,
                base + 0x80,
                base + 0xff,
                base + 0x100,
            ]
        })
        .collect();
    let check = |state: &State| {
        for &address in &probes {
            assert_eq!(
                indexed_buffers_at(state, address),
                reference_buffers_at(state, address),
                "buffers at {address:#x}"
            );
        }
    };
    check(&state);

    for handle in (1..=count as Handle).step_by(3) {
        state.buffers.remove(&handle);
    }
    check(&state);
    assert!(state.knows_addresses());
}
