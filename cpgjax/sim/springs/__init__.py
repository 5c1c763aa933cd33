"""The thesis's pipeline: every body free, each revolute joint two stiff damped pivot springs (eq. 3.6)."""
