"""Control of the painting task (§V): joint PD + gravity (eq. 13), external force estimation (eq. 14),
force PI (eq. 15) and the contact simulation loop."""
