// SPDX-License-Identifier: GPL-2.0
/* contego.ko: bindings: which task the calling process acts as. */
#include "contego.h"

/* The caller's cgroup v2 path into ct.cgroup_buf, as the initial cgroup
 * namespace sees it (a process cannot move its own root with a namespace of
 * its own). task_cgroup_path() would give a v1 hierarchy's path.
 */
static bool ct_current_cgroup_path(void)
{
	struct cgroup *cgrp;
	int ret;

	lockdep_assert_held(&ct.lock);
	rcu_read_lock();
	cgrp = task_dfl_cgroup(current);
	cgroup_get(cgrp);
	rcu_read_unlock();
	ret = cgroup_path_ns(cgrp, ct.cgroup_buf, sizeof(ct.cgroup_buf),
			     init_task.nsproxy->cgroup_ns);
	cgroup_put(cgrp);
	return ret >= 0 && ret < (int)sizeof(ct.cgroup_buf);
}

/* Whether `path` is `cg` or below it. */
static bool ct_cgroup_under(const char *path, const char *cg)
{
	size_t n = strlen(cg);

	if (strcmp(cg, "/") == 0)
		return true;
	return strncmp(path, cg, n) == 0 && (path[n] == '\0' || path[n] == '/');
}

/* Whether a component of `path` is `unit`. */
static bool ct_cgroup_has_unit(const char *path, const char *unit)
{
	size_t n = strlen(unit);
	const char *c = path;

	while ((c = strstr(c, unit)) != NULL) {
		if ((c == path || c[-1] == '/') && (c[n] == '\0' || c[n] == '/'))
			return true;
		c += n;
	}
	return false;
}

/* Whether the caller runs the executable (dev, ino) -- as stat(2) of it says. */
static bool ct_current_exe_is(const struct contego_kmod_bind *b)
{
	struct mm_struct *mm = current->mm;
	struct file *exe = NULL;
	struct kstat st;
	bool same = false;

	if (!mm)
		return false;
	exe = ct_get_exe_file(mm);
	if (!exe)
		return false;
	if (vfs_getattr(&exe->f_path, &st, STATX_INO, AT_STATX_SYNC_AS_STAT) == 0)
		same = st.ino == b->exe_ino && MAJOR(st.dev) == b->exe_major &&
		       MINOR(st.dev) == b->exe_minor;
	fput(exe);
	return same;
}

/* The caller's task: the first binding whose every fact it meets. Under ct.lock. */
u16 ct_task_of_current(const struct ct_policy *p)
{
	u32 uid = from_kuid(&init_user_ns, current_euid());
	bool have_cgroup = false, cgroup_known = false;
	u32 i;

	lockdep_assert_held(&ct.lock);
	for (i = 0; i < p->nbinds; i++) {
		const struct contego_kmod_bind *b = &p->binds[i];

		if (b->uid != CONTEGO_KMOD_ANY && b->uid != uid)
			continue;
		if (b->gid != CONTEGO_KMOD_ANY && !in_egroup_p(make_kgid(&init_user_ns, b->gid)))
			continue;
		if ((b->flags & CONTEGO_KMOD_BIND_EXE) && !ct_current_exe_is(b))
			continue;
		if (b->cgroup[0] || b->unit[0]) {
			if (!have_cgroup) {
				have_cgroup = true;
				cgroup_known = ct_current_cgroup_path();
			}
			if (!cgroup_known)
				continue;
			if (b->cgroup[0] && !ct_cgroup_under(ct.cgroup_buf, b->cgroup))
				continue;
			if (b->unit[0] && !ct_cgroup_has_unit(ct.cgroup_buf, b->unit))
				continue;
		}
		return b->task;
	}
	return CONTEGO_NONE;
}
