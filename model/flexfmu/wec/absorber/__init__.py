"""The reference point absorber: a floating vertical circular cylinder (radius 5 m, draft 3 m) with a heave PTO,
as four co-simulation components and the existing Mooring (/work/pa_spec.md is their contract with the native C
forms): the hull's hydrodynamic data (hull), the sea (wave), the rigid body (float_body), hydrostatic restoring,
radiation memory and drag (hydro), the PTO (pto), and the frequency-domain prediction (frequency_domain).

Importing this package imports nothing: the hull data needs Capytaine (flexfmu.wec.bem)."""
