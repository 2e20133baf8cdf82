// SPDX-License-Identifier: GPL-2.0
/* contego.ko: the nodes /dev/i2c-N: open, read, write and i2c-dev's ioctls. */
#include "contego.h"

struct ct_node *ct_node_for_bus(u8 bus)
{
	int i;

	for (i = 0; i < ct.node_count; i++)
		if (ct.nodes[i].bus == bus)
			return &ct.nodes[i];
	return NULL;
}

/* ---- write() and read() -------------------------------------------------- */

static ssize_t ct_write(struct file *file, const char __user *buf, size_t count, loff_t *off)
{
	struct ct_file *cf = file->private_data;
	struct i2c_msg m = { .addr = cf->addr, .flags = cf->flags & I2C_M_TEN };
	u32 decider;
	u64 hold_until;
	u8 *tmp, action;
	u16 task;
	int ret;

	if (count > CT_MAX_LEN)
		count = CT_MAX_LEN;
	tmp = memdup_user(buf, count);
	if (IS_ERR(tmp))
		return PTR_ERR(tmp);
	m.len = count;
	m.buf = tmp;
	if (mutex_lock_killable(&ct.lock)) {
		kfree(tmp);
		return -EINTR;
	}
	/* No form on this adapter: refused before the core decides, and
	 * recorded, as the monitor does (read() and I2C_RDWR alike).
	 */
	if (!ct_msg_expressible(cf, &m)) {
		mutex_unlock(&ct.lock);
		kfree(tmp);
		return -EOPNOTSUPP;
	}
	ret = ct_enter(true, &task);
	if (ret < 0) {
		mutex_unlock(&ct.lock);
		kfree(tmp);
		return ret;
	}
	ct.txs[0] = (struct contego_i2c_tx){ .kind = CONTEGO_TX_WRITE, .addr = cf->addr,
				   .ten = !!(cf->flags & I2C_M_TEN), .len = count, .bytes = tmp };
	action = ct_decide(cf, task, &m, 1, 1, &decider, &hold_until);
	if ((action == CT_PERFORM || action == CT_SUBSTITUTE) &&
	    contego_i2c_emits_as_sent(&ct.verdicts[0], cf->addr, tmp, count))
		ret = ct_xfer(cf->adap, cf, &m, 1, false); /* as sent: one message */
	else if (action == CT_PERFORM || action == CT_SUBSTITUTE)
		ret = ct_perform_emits(cf->adap, cf, &ct.verdicts[0], cf->flags);
	else if (action == CT_REFUSE)
		ret = ct_refusal(decider);
	else
		ret = 0;
	mutex_unlock(&ct.lock);
	ct_hold_after(hold_until);
	kfree(tmp);
	return ret < 0 ? ret : count;
}

static ssize_t ct_read(struct file *file, char __user *buf, size_t count, loff_t *off)
{
	struct ct_file *cf = file->private_data;
	struct i2c_msg m = { .addr = cf->addr, .flags = I2C_M_RD | (cf->flags & I2C_M_TEN) };
	u32 decider;
	u64 hold_until;
	u8 *tmp, action;
	u16 task;
	int ret;

	if (count > CT_MAX_LEN)
		count = CT_MAX_LEN;
	m.len = count;
	tmp = kzalloc(count ? count : 1, GFP_KERNEL);
	if (!tmp)
		return -ENOMEM;
	m.buf = tmp;
	if (mutex_lock_killable(&ct.lock)) {
		kfree(tmp);
		return -EINTR;
	}
	if (!ct_msg_expressible(cf, &m)) { /* no form on this adapter: recorded */
		mutex_unlock(&ct.lock);
		kfree(tmp);
		return -EOPNOTSUPP;
	}
	ct_enter(false, &task); /* a read is never held */
	ct.txs[0] = (struct contego_i2c_tx){ .kind = CONTEGO_TX_READ, .addr = cf->addr,
					     .ten = !!(cf->flags & I2C_M_TEN) };
	action = ct_decide(cf, task, &m, 1, 1, &decider, &hold_until);
	if (action == CT_PERFORM)
		ret = ct_xfer(cf->adap, cf, &m, 1, false);
	else if (action == CT_REFUSE)
		ret = ct_refusal(decider);
	else
		ret = 0; /* ignored: it succeeds and reads nothing (zeros) */
	mutex_unlock(&ct.lock);
	ct_hold_after(hold_until);
	if (ret == 0 && copy_to_user(buf, tmp, count))
		ret = -EFAULT;
	kfree(tmp);
	return ret < 0 ? ret : count;
}

/* ---- the node ------------------------------------------------------------ */

static int ct_check_addr_busy(struct device *dev, void *addrp)
{
	struct i2c_client *client = i2c_verify_client(dev);

	if (!client || client->addr != *(unsigned int *)addrp)
		return 0;
	return dev->driver ? -EBUSY : 0;
}

static long ct_ioctl(struct file *file, unsigned int cmd, unsigned long arg)
{
	struct ct_file *cf = file->private_data;
	unsigned int addr;

	switch (cmd) {
	case I2C_SLAVE:
	case I2C_SLAVE_FORCE:
		if (arg > 0x3ff || ((cf->flags & I2C_M_TEN) == 0 && arg > 0x7f))
			return -EINVAL;
		addr = arg;
		if (cmd == I2C_SLAVE &&
		    device_for_each_child(&cf->adap->dev, &addr, ct_check_addr_busy))
			return -EBUSY;
		/* No check here: the address is checked with each transaction. */
		cf->addr = arg;
		return 0;
	case I2C_TENBIT:
	case I2C_PEC: {
		u16 flag = cmd == I2C_TENBIT ? I2C_M_TEN : I2C_CLIENT_PEC;

		cf->flags = arg ? cf->flags | flag : cf->flags & ~flag;
		return 0;
	}
	case I2C_FUNCS:
		return put_user(i2c_get_functionality(cf->adap), (unsigned long __user *)arg);
	case I2C_RDWR:
		return ct_rdwr(cf, arg);
	case I2C_SMBUS: {
		struct i2c_smbus_ioctl_data a;

		if (copy_from_user(&a, (void __user *)arg, sizeof(a)))
			return -EFAULT;
		return ct_smbus(cf, a);
	}
	case I2C_RETRIES:
	case I2C_TIMEOUT:
		/* This descriptor's own (ct_bus_transfer), not the adapter's:
		 * an unprivileged caller cannot change another's transfers.
		 * The limits are i2c-dev's (arg * 10 must not wrap), in the
		 * model contego run shares.
		 */
		if (!contego_i2c_timing_arg_ok(cmd == I2C_TIMEOUT, arg))
			return -EINVAL;
		if (mutex_lock_killable(&ct.lock))
			return -EINTR;
		if (!cf->own_timing) {
			cf->retries = cf->adap->retries;
			cf->timeout = cf->adap->timeout;
			cf->own_timing = true;
		}
		if (cmd == I2C_RETRIES)
			cf->retries = arg;
		else
			cf->timeout = msecs_to_jiffies(arg * 10);
		mutex_unlock(&ct.lock);
		return 0;
	default:
		return -ENOTTY;
	}
}

#ifdef CONFIG_COMPAT
/* 32-bit programs on a 64-bit kernel (armhf Raspberry Pi OS on its arm64
 * kernel, i386 on amd64): i2c-dev's compat layouts, converted, then the
 * native paths. Scalar requests are the same in both ABIs.
 */
struct ct_msg32 {
	u16 addr;
	u16 flags;
	u16 len;
	compat_caddr_t buf;
};

struct ct_rdwr32 {
	compat_caddr_t msgs;
	u32 nmsgs;
};

struct ct_smbus32 {
	u8 read_write;
	u8 command;
	u32 size;
	compat_caddr_t data;
};

static long ct_compat_rdwr(struct ct_file *cf, unsigned long arg)
{
	struct ct_msg32 __user *umsgs;
	struct ct_rdwr32 rd;
	struct i2c_msg *msgs;
	long ret = 0;
	u32 i;

	if (copy_from_user(&rd, compat_ptr(arg), sizeof(rd)))
		return -EFAULT;
	if (!rd.msgs || rd.nmsgs == 0 || rd.nmsgs > CT_MAX_MSGS)
		return -EINVAL;
	msgs = kcalloc(rd.nmsgs, sizeof(*msgs), GFP_KERNEL);
	if (!msgs)
		return -ENOMEM;
	umsgs = compat_ptr(rd.msgs);
	for (i = 0; i < rd.nmsgs; i++) {
		struct ct_msg32 m;

		if (copy_from_user(&m, &umsgs[i], sizeof(m))) {
			ret = -EFAULT;
			goto out;
		}
		msgs[i] = (struct i2c_msg){ .addr = m.addr, .flags = m.flags, .len = m.len,
					    .buf = (__force u8 *)compat_ptr(m.buf) };
	}
	ret = ct_rdwr_msgs(cf, msgs, rd.nmsgs);
out:
	kfree(msgs);
	return ret;
}

static long ct_compat_ioctl(struct file *file, unsigned int cmd, unsigned long arg)
{
	struct ct_file *cf = file->private_data;

	switch (cmd) {
	case I2C_FUNCS:
		return put_user(i2c_get_functionality(cf->adap),
				(compat_ulong_t __user *)compat_ptr(arg));
	case I2C_RDWR:
		return ct_compat_rdwr(cf, arg);
	case I2C_SMBUS: {
		struct ct_smbus32 a;

		if (copy_from_user(&a, compat_ptr(arg), sizeof(a)))
			return -EFAULT;
		return ct_smbus(cf, (struct i2c_smbus_ioctl_data){
			.read_write = a.read_write, .command = a.command, .size = a.size,
			.data = compat_ptr(a.data) });
	}
	default:
		return ct_ioctl(file, cmd, arg);
	}
}
#endif

static int ct_open(struct inode *inode, struct file *file)
{
	struct ct_node *node = container_of(inode->i_cdev, struct ct_node, cdev);
	struct ct_file *cf;
	struct i2c_adapter *adap;

	adap = i2c_get_adapter(node->nr);
	if (!adap)
		return -ENODEV;
	cf = kzalloc(sizeof(*cf), GFP_KERNEL);
	if (!cf) {
		i2c_put_adapter(adap);
		return -ENOMEM;
	}
	cf->adap = adap;
	cf->bus = node->bus;
	file->private_data = cf;
	return 0;
}

static int ct_release(struct inode *inode, struct file *file)
{
	struct ct_file *cf = file->private_data;

	i2c_put_adapter(cf->adap);
	kfree(cf);
	file->private_data = NULL;
	return 0;
}

const struct file_operations ct_node_fops = {
	.owner = THIS_MODULE,
	.llseek = CT_NO_LLSEEK,
	.read = ct_read,
	.write = ct_write,
	.unlocked_ioctl = ct_ioctl,
#ifdef CONFIG_COMPAT
	.compat_ioctl = ct_compat_ioctl,
#endif
	.open = ct_open,
	.release = ct_release,
};
