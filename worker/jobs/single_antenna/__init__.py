"""The methods of job type single-antenna-attitude, one module each (see worker/jobs/single_antenna_attitude.py)."""
