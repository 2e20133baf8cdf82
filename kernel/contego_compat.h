/* SPDX-License-Identifier: GPL-2.0 */
/*
 * contego.ko: every difference between the kernels it builds for (6.1 to
 * 6.12, docs/kernel-client.md), in one place.
 */
#ifndef CONTEGO_COMPAT_H
#define CONTEGO_COMPAT_H

#include <linux/device.h>
#include <linux/fs.h>
#include <linux/mm_types.h>
#include <linux/rcupdate.h>
#include <linux/version.h>

/* 6.2: a class's devnode() and dev_uevent() take a const device. */
#if LINUX_VERSION_CODE >= KERNEL_VERSION(6, 2, 0)
#define CT_CLASS_DEV const struct device
#else
#define CT_CLASS_DEV struct device
#endif

/* 6.4: class_create() lost its owner argument. */
#if LINUX_VERSION_CODE >= KERNEL_VERSION(6, 4, 0)
#define ct_class_create(name) class_create(name)
#else
#define ct_class_create(name) class_create(THIS_MODULE, name)
#endif

/* 6.12: no .llseek is no seeking; before, no_llseek says so. */
#if LINUX_VERSION_CODE < KERNEL_VERSION(6, 12, 0)
#define CT_NO_LLSEEK no_llseek
#else
#define CT_NO_LLSEEK NULL
#endif

/*
 * A reference to mm's executable file, or NULL: get_mm_exe_file() is not
 * exported, so its RCU read is done here. 6.7 made get_file_rcu() take the
 * RCU pointer itself.
 */
static inline struct file *ct_get_exe_file(struct mm_struct *mm)
{
	struct file *exe;

	rcu_read_lock();
#if LINUX_VERSION_CODE >= KERNEL_VERSION(6, 7, 0)
	exe = get_file_rcu(&mm->exe_file);
#else
	exe = rcu_dereference(mm->exe_file);
	if (exe && !get_file_rcu(exe))
		exe = NULL;
#endif
	rcu_read_unlock();
	return exe;
}

#endif /* CONTEGO_COMPAT_H */
