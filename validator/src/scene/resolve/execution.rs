//! Resolving the execution-order calls of a scene (`format::execution`):
//! queues, fences and semaphores get handles where first named.

use crate::model::command::{SemaphoreOp, SubmitBatch};
use crate::model::pipeline::SubmitInfo2;
use crate::model::Handle;
use crate::report::Report;

use super::super::args::HandleArg;
use super::super::format::*;
use super::{ObjectKind, Resolver, Result};

/// The queue a submission without `queue` goes to.
const DEFAULT_QUEUE: Handle = 0x9e_0000;

/// A semaphore's operation: one given a value other than 0 is a timeline semaphore.
fn semaphore_op(semaphore: Handle, value: u64) -> SemaphoreOp {
    SemaphoreOp {
        semaphore,
        value,
        timeline: value != 0,
    }
}

impl Resolver<'_> {
    fn queue(&mut self, arg: &HandleArg, at: &str) -> Result<Handle> {
        match arg {
            HandleArg::Omitted => Ok(DEFAULT_QUEUE),
            other => self.loose_handle(other, ObjectKind::Queue, &format!("{at}.queue")),
        }
    }

    fn loose_handles(
        &mut self,
        args: &[HandleArg],
        kind: ObjectKind,
        at: &str,
    ) -> Result<Vec<Handle>> {
        args.iter()
            .enumerate()
            .map(|(k, arg)| self.loose_handle(arg, kind, &format!("{at}[{k}]")))
            .collect()
    }

    /// Semaphores with their values (absent values are 0).
    fn semaphore_ops(
        &mut self,
        semaphores: &[HandleArg],
        values: &[u64],
        at: &str,
    ) -> Result<Vec<SemaphoreOp>> {
        let handles = self.loose_handles(semaphores, ObjectKind::Semaphore, at)?;
        Ok(handles
            .into_iter()
            .enumerate()
            .map(|(k, s)| semaphore_op(s, values.get(k).copied().unwrap_or(0)))
            .collect())
    }

    fn command_buffer_handles<'c>(
        &self,
        args: impl Iterator<Item = &'c CommandBufferArg>,
        at: &str,
    ) -> Result<Vec<Handle>> {
        args.enumerate()
            .map(|(k, arg)| Ok(self.command_buffer(arg, &format!("{at}[{k}]"))?.handle))
            .collect()
    }

    /// The execution side of `vkQueueSubmit2`: its batches run in order.
    pub(super) fn submit2_execution(
        &mut self,
        c: &QueueSubmit2,
        submits: &[SubmitInfo2],
        at: &str,
    ) -> Result<Report> {
        let queue = self.queue(&c.queue, at)?;
        let fence = self.loose_handle(&c.fence, ObjectKind::Fence, &format!("{at}.fence"))?;
        let mut batches = Vec::with_capacity(submits.len());
        for (i, (d, submit)) in c.p_submits.iter().zip(submits).enumerate() {
            let ops = |infos: &[crate::model::pipeline::SemaphoreSubmitInfo]| {
                infos
                    .iter()
                    .map(|s| semaphore_op(s.semaphore, s.value))
                    .collect()
            };
            batches.push(SubmitBatch {
                waits: ops(&submit.wait_semaphore_infos),
                command_buffers: self.command_buffer_handles(
                    d.p_command_buffer_infos
                        .iter()
                        .map(|info| &info.command_buffer),
                    &format!("{at}.pSubmits[{i}].pCommandBufferInfos"),
                )?,
                signals: ops(&submit.signal_semaphore_infos),
            });
        }
        Ok(self
            .validator
            .queue_submit("vkQueueSubmit2", queue, &batches, fence))
    }

    pub(super) fn execution_call(&mut self, call: &ExecutionCall, at: &str) -> Result<Report> {
        match call {
            ExecutionCall::BeginCommandBuffer { command_buffer } => {
                let handle = self.command_buffer(command_buffer, at)?.handle;
                self.validator.begin_command_buffer(handle);
            }
            ExecutionCall::EndCommandBuffer { command_buffer } => {
                self.command_buffer(command_buffer, at)?;
            }
            ExecutionCall::CmdExecuteCommands {
                command_buffer,
                p_command_buffers,
            } => {
                let primary = self.command_buffer(command_buffer, at)?.handle;
                let secondaries = self.command_buffer_handles(
                    p_command_buffers.iter(),
                    &format!("{at}.pCommandBuffers"),
                )?;
                self.validator.cmd_execute_commands(primary, &secondaries);
            }
            ExecutionCall::QueueSubmit {
                queue,
                p_submits,
                fence,
            } => {
                let queue = self.queue(queue, at)?;
                let fence = self.loose_handle(fence, ObjectKind::Fence, &format!("{at}.fence"))?;
                let mut batches = Vec::with_capacity(p_submits.len());
                for (i, d) in p_submits.iter().enumerate() {
                    let submit_at = format!("{at}.pSubmits[{i}]");
                    batches.push(SubmitBatch {
                        waits: self.semaphore_ops(
                            &d.p_wait_semaphores,
                            &d.p_wait_semaphore_values,
                            &format!("{submit_at}.pWaitSemaphores"),
                        )?,
                        command_buffers: self.command_buffer_handles(
                            d.p_command_buffers.iter(),
                            &format!("{submit_at}.pCommandBuffers"),
                        )?,
                        signals: self.semaphore_ops(
                            &d.p_signal_semaphores,
                            &d.p_signal_semaphore_values,
                            &format!("{submit_at}.pSignalSemaphores"),
                        )?,
                    });
                }
                return Ok(self
                    .validator
                    .queue_submit("vkQueueSubmit", queue, &batches, fence));
            }
            ExecutionCall::WaitForFences {
                p_fences, wait_all, ..
            } => {
                let fences =
                    self.loose_handles(p_fences, ObjectKind::Fence, &format!("{at}.pFences"))?;
                // Waiting for any one of several fences tells which only to
                // the application: nothing is known complete.
                if *wait_all || fences.len() == 1 {
                    self.validator.fences_signalled(&fences);
                }
            }
            ExecutionCall::ResetFences { p_fences, .. } => {
                let fences =
                    self.loose_handles(p_fences, ObjectKind::Fence, &format!("{at}.pFences"))?;
                self.validator.reset_fences(&fences);
            }
            ExecutionCall::QueueWaitIdle { queue } => {
                let queue = self.queue(queue, at)?;
                self.validator.queue_wait_idle(queue);
            }
            ExecutionCall::DeviceWaitIdle { .. } => self.validator.device_wait_idle(),
            ExecutionCall::WaitSemaphores { p_wait_info, .. } => {
                let semaphores = self.loose_handles(
                    &p_wait_info.p_semaphores,
                    ObjectKind::Semaphore,
                    &format!("{at}.pWaitInfo.pSemaphores"),
                )?;
                // VK_SEMAPHORE_WAIT_ANY_BIT: which one was reached is not known.
                const WAIT_ANY: u32 = 0x1;
                if p_wait_info.flags & WAIT_ANY == 0 || semaphores.len() == 1 {
                    for (semaphore, value) in semaphores.into_iter().zip(&p_wait_info.p_values) {
                        self.validator.semaphore_reached(semaphore, *value);
                    }
                }
            }
            ExecutionCall::SignalSemaphore { p_signal_info, .. } => {
                let semaphore = self.loose_handle(
                    &p_signal_info.semaphore,
                    ObjectKind::Semaphore,
                    &format!("{at}.pSignalInfo.semaphore"),
                )?;
                return Ok(self
                    .validator
                    .signal_semaphore(semaphore, p_signal_info.value));
            }
            ExecutionCall::DestroySemaphore { semaphore, .. } => {
                let semaphore = self.loose_handle(
                    semaphore,
                    ObjectKind::Semaphore,
                    &format!("{at}.semaphore"),
                )?;
                self.validator.destroy_semaphore(semaphore);
            }
            ExecutionCall::CmdResetQueryPool {
                command_buffer,
                query_pool,
                first_query,
                query_count,
            } => {
                let cb = self.command_buffer(command_buffer, at)?;
                let pool = self.handle(
                    query_pool,
                    ObjectKind::QueryPool,
                    &format!("{at}.queryPool"),
                )?;
                return Ok(self.validator.cmd_reset_query_pool(
                    &cb,
                    pool,
                    *first_query,
                    *query_count,
                ));
            }
            ExecutionCall::ResetQueryPool {
                query_pool,
                first_query,
                query_count,
                ..
            } => {
                let pool = self.handle(
                    query_pool,
                    ObjectKind::QueryPool,
                    &format!("{at}.queryPool"),
                )?;
                return Ok(self
                    .validator
                    .reset_query_pool(pool, *first_query, *query_count));
            }
            ExecutionCall::DeferredOperationJoin { operation, .. } => {
                let operation = self.handle(
                    operation,
                    ObjectKind::DeferredOperation,
                    &format!("{at}.operation"),
                )?;
                self.validator.deferred_operation_completed(operation);
            }
        }
        Ok(Report::new())
    }
}
