// SPDX-License-Identifier: GPL-2.0
/*
 * contego.ko: the checked i2c-dev (docs/kernel-client.md).
 *
 * It takes i2c-dev's place (character major 89, class "i2c-dev", nodes
 * /dev/i2c-N) for the adapters it is told to protect, so unmodified programs
 * opening /dev/i2c-N are checked with no help from them: every write, read,
 * I2C_RDWR and I2C_SMBUS is copied from user memory once, turned into the
 * trusted core's transactions (the same normalisation as contego's gate,
 * docs/gate-protocol.md "Normalisation"), decided by the core -- the same
 * sources as user space, compiled with the kernel's flags -- and only what the
 * core allowed or substituted reaches the adapter.
 *
 * Policy: /dev/contego (root only) takes a compiled image with the
 * CONTEGO_KMOD_LOAD ioctl; the core's verifier checks it in a fresh checker
 * before it replaces the one in force, so a bad image is refused and the old
 * one stays. Until an image is loaded, and for a process no binding names,
 * the core answers its default: deny.
 */
#include "contego.h"

static int adapters[CT_MAX_ADAPTERS];
static int n_adapters;
module_param_array(adapters, int, &n_adapters, 0444);
MODULE_PARM_DESC(adapters, "adapter numbers to protect (/dev/i2c-N); default 0");
static int buses[CT_MAX_ADAPTERS];
static int n_buses;
module_param_array(buses, int, &n_buses, 0444);
MODULE_PARM_DESC(buses,
		 "the policy's bus number of each protected adapter (`at i2c-B`); default: the adapter's number");

bool ct_trace;
module_param_named(trace, ct_trace, bool, 0644);
MODULE_PARM_DESC(trace, "log every decision to the kernel log (debugging; not the audit log)");

static unsigned int audit_records = 16384;
module_param(audit_records, uint, 0444);
MODULE_PARM_DESC(audit_records, "records the audit ring holds until the reader acknowledges them");

unsigned int ct_max_sessions = 1024;
module_param_named(max_sessions, ct_max_sessions, uint, 0444);
MODULE_PARM_DESC(max_sessions,
		 "sessions open at once, all tasks together; a call that would open one more is refused (EAGAIN)");

struct ct_state ct = {
	.lock = __MUTEX_INITIALIZER(ct.lock),
	.sessions = LIST_HEAD_INIT(ct.sessions),
	.ring = {
		.lock = __SPIN_LOCK_UNLOCKED(ct.ring.lock),
		.wait = __WAIT_QUEUE_HEAD_INITIALIZER(ct.ring.wait),
	},
};

/*
 * The nodes are open to every user: the module, not the file mode, decides
 * who may act (an unbound process gets the policy's default). CONTEGO_KMOD=1
 * in the uevent lets udev rules tell these nodes from i2c-dev's (the
 * package's rule hands i2c-dev's to the monitor alone, and keeps off these).
 */
static char *ct_devnode(CT_CLASS_DEV *dev, umode_t *mode)
{
	if (mode)
		*mode = 0666;
	return NULL;
}

static int ct_dev_uevent(CT_CLASS_DEV *dev, struct kobj_uevent_env *env)
{
	return add_uevent_var(env, "CONTEGO_KMOD=1");
}

static void ct_remove_nodes(void)
{
	int i;

	for (i = 0; i < ct.node_count; i++) {
		if (ct.nodes[i].dev)
			device_destroy(ct.i2c_class, MKDEV(I2C_MAJOR, ct.nodes[i].nr));
		if (ct.nodes[i].registered) {
			cdev_del(&ct.nodes[i].cdev);
			unregister_chrdev_region(MKDEV(I2C_MAJOR, ct.nodes[i].nr), 1);
		}
	}
	ct.node_count = 0;
}

/* Node /dev/i2c-N of adapter `nr`, checked as the policy's bus `bus`. */
static int ct_add_node(int nr, u8 bus)
{
	struct ct_node *node = &ct.nodes[ct.node_count];
	struct i2c_adapter *adap;
	dev_t devt = MKDEV(I2C_MAJOR, nr);
	int ret;

	node->nr = nr;
	node->bus = bus;
	ct.node_count++;
	adap = i2c_get_adapter(nr);
	if (!adap) {
		pr_err("contego: no adapter i2c-%d\n", nr);
		return -ENODEV;
	}
	ret = register_chrdev_region(devt, 1, "i2c");
	if (ret) {
		pr_err("contego: char device %d:%d taken (unload i2c-dev first)\n", I2C_MAJOR, nr);
		goto put_adapter;
	}
	cdev_init(&node->cdev, &ct_node_fops);
	node->cdev.owner = THIS_MODULE;
	ret = cdev_add(&node->cdev, devt, 1);
	if (ret)
		goto unregister;
	node->registered = true;
	node->dev = device_create(ct.i2c_class, &adap->dev, devt, NULL, "i2c-%d", nr);
	if (IS_ERR(node->dev)) {
		ret = PTR_ERR(node->dev);
		node->dev = NULL;
		goto put_adapter; /* ct_remove_nodes() deletes the cdev */
	}
	i2c_put_adapter(adap);
	pr_info("contego: /dev/i2c-%d checked as the policy's bus %u\n", nr, bus);
	return 0;
unregister:
	unregister_chrdev_region(devt, 1);
put_adapter:
	i2c_put_adapter(adap);
	return ret;
}

/* An audit record of a protected adapter going or coming back. */
static void ct_record_adapter(const struct ct_node *node, u8 why)
{
	struct contego_kmod_record r;

	ct_record_start(&r, CONTEGO_KMOD_REC_ADAPTER, false);
	r.bus = node->bus;
	r.why = why;
	r.count = node->nr;
	ct_push(&r, true); /* rare, and what the log must not lose */
}

/*
 * The devices on adapters that came back: their samples dropped and their
 * shadows read back from the chips, then their safe state. What the chips hold now (a new adapter, a
 * chip reset with it) is not what the checks last allowed. From the work
 * queue, once the adapter is registered.
 */
static void ct_adapter_work(struct work_struct *w)
{
	contego_device_info info;
	u32 n, d;
	int i;

	mutex_lock(&ct.lock);
	for (i = 0; i < ct.node_count; i++) {
		struct ct_node *node = &ct.nodes[i];

		if (!node->returned || ct.unloading)
			continue;
		node->returned = false;
		if (!ct.policy)
			continue;
		for (d = 0; d < CONTEGO_MAX_DEVICES; d++)
			if (contego_device_info_of(ct.policy->checker, d, &info) && info.bus == node->bus)
				ct.policy->samples[d].valid = false;
		ct_seed_shadows(ct.policy, node->bus);
		n = ct_drive_safe_states_on(ct.policy, node->bus, CONTEGO_KMOD_SAFE_ADAPTER);
		pr_info("contego: adapter i2c-%d is back as the policy's bus %u: %u devices driven to their safe state\n",
			node->nr, node->bus, n);
	}
	mutex_unlock(&ct.lock);
}

/*
 * A protected adapter removed (a driver unbound, its module unloaded) takes
 * its node with it, as i2c-dev's does: nothing is written to it while it is
 * away, and a session's end then records its safe state as failed. Added
 * again under the same number, it gets its node back and its devices their
 * safe state. Both are audited.
 */
static int ct_adapter_notify(struct notifier_block *nb, unsigned long action, void *data)
{
	struct i2c_adapter *adap = i2c_verify_adapter(data);
	struct ct_node *node = NULL;
	int i;

	if (!adap || (action != BUS_NOTIFY_ADD_DEVICE && action != BUS_NOTIFY_DEL_DEVICE))
		return NOTIFY_DONE;
	for (i = 0; i < ct.node_count; i++)
		if (ct.nodes[i].nr == adap->nr)
			node = &ct.nodes[i];
	if (!node || !node->registered)
		return NOTIFY_DONE;
	mutex_lock(&ct.lock);
	if (action == BUS_NOTIFY_DEL_DEVICE && node->dev) {
		device_destroy(ct.i2c_class, MKDEV(I2C_MAJOR, node->nr));
		node->dev = NULL;
		node->returned = false;
		ct_record_adapter(node, CONTEGO_KMOD_ADAPTER_REMOVED);
		pr_warn("contego: adapter i2c-%d removed: /dev/i2c-%d is gone until it comes back\n",
			node->nr, node->nr);
	} else if (action == BUS_NOTIFY_ADD_DEVICE && !node->dev) {
		node->dev = device_create(ct.i2c_class, &adap->dev, MKDEV(I2C_MAJOR, node->nr), NULL,
					  "i2c-%d", node->nr);
		if (IS_ERR(node->dev)) {
			pr_err("contego: adapter i2c-%d is back but its node cannot be made (%ld)\n",
			       node->nr, PTR_ERR(node->dev));
			node->dev = NULL;
		} else {
			ct_record_adapter(node, CONTEGO_KMOD_ADAPTER_ADDED);
			node->returned = true;
			queue_work(ct.wq, &ct.adapter_work);
		}
	}
	mutex_unlock(&ct.lock);
	return NOTIFY_OK;
}

static struct notifier_block ct_adapter_nb = {
	.notifier_call = ct_adapter_notify,
};

static int __init ct_init(void)
{
	int i, ret;

	if (n_adapters == 0) {
		adapters[0] = 0;
		n_adapters = 1;
	}
	/* The record layout `contego kmod audit` reads (kmod_audit.cc asserts it too). */
	BUILD_BUG_ON(sizeof(struct contego_kmod_record) != 136);
	/* CONTEGO_KMOD_LOAD_VERSION 4's layout (kmod_command.cc asserts it too). */
	BUILD_BUG_ON(sizeof(struct contego_kmod_load) != 360);
	if (ct_max_sessions < 1 || ct_max_sessions > 65536) {
		pr_err("contego: max_sessions=%u: give 1 .. 65536\n", ct_max_sessions);
		return -EINVAL;
	}
	if (audit_records < 64 || audit_records > (1u << 20)) {
		pr_err("contego: audit_records=%u: give 64 .. 1048576\n", audit_records);
		return -EINVAL;
	}
	INIT_WORK(&ct.adapter_work, ct_adapter_work);
	ct.ring.cap = audit_records;
	ct.ring.records = vmalloc_array(ct.ring.cap, sizeof(*ct.ring.records));
	if (!ct.ring.records)
		return -ENOMEM;
	ct.wq = alloc_workqueue("contego", 0, 0);
	if (!ct.wq) {
		ret = -ENOMEM;
		goto free_ring;
	}
	ct.i2c_class = ct_class_create("i2c-dev");
	if (IS_ERR(ct.i2c_class)) {
		pr_err("contego: cannot create class i2c-dev (is i2c-dev loaded? contego.ko replaces it)\n");
		ret = PTR_ERR(ct.i2c_class);
		goto destroy_wq;
	}
	ct.i2c_class->devnode = ct_devnode;
	ct.i2c_class->dev_uevent = ct_dev_uevent;
	for (i = 0; i < n_adapters; i++) {
		ret = ct_add_node(adapters[i], i < n_buses ? buses[i] : adapters[i]);
		if (ret)
			goto remove_nodes;
	}
	ret = misc_register(&ct_ctl);
	if (ret)
		goto remove_nodes;
	ret = misc_register(&ct_audit_dev);
	if (ret)
		goto deregister_ctl;
	ret = bus_register_notifier(&i2c_bus_type, &ct_adapter_nb);
	if (ret)
		goto deregister_audit;
	return 0;

deregister_audit:
	misc_deregister(&ct_audit_dev);
deregister_ctl:
	misc_deregister(&ct_ctl);
remove_nodes:
	ct_remove_nodes();
	class_destroy(ct.i2c_class);
destroy_wq:
	destroy_workqueue(ct.wq);
free_ring:
	vfree(ct.ring.records);
	return ret;
}

static void __exit ct_exit(void)
{
	bus_unregister_notifier(&i2c_bus_type, &ct_adapter_nb);
	misc_deregister(&ct_audit_dev);
	misc_deregister(&ct_ctl);
	/* No session can end from here on (the unload drives every device). */
	ct_sessions_stop();
	/* No node is open (each open holds the module): the actuators go to
	 * their safe state before the checker and the nodes go away.
	 */
	mutex_lock(&ct.lock);
	if (ct.policy)
		pr_info("contego: unloading: %u devices driven to their safe state\n",
			ct_drive_safe_states(ct.policy, CONTEGO_KMOD_SAFE_UNLOAD, NULL));
	mutex_unlock(&ct.lock);
	ct_remove_nodes();
	class_destroy(ct.i2c_class);
	ct_policy_free(ct.policy);
	ct.policy = NULL;
	vfree(ct.ring.records);
}

module_init(ct_init);
module_exit(ct_exit);
MODULE_DESCRIPTION("contego: i2c-dev with the trusted core's checks in the kernel");
MODULE_LICENSE("GPL");
