//! The object tree and the grouping and geometric operations on it (thesis Table 2.4).
//!
//! Shape of the tree: an object is either a *part* (primitives, and the transformations
//! that place them) or a *group* (child objects, no transformations and no primitives of its
//! own). YARI applies an outer block's transformations to a point before an inner block's,
//! so a transformation written on a group would act inside its children's own rotations and
//! scalings; keeping transformations on parts lets "translate this composite by v" append
//! `translate(v)` to every part and move every part by exactly v in world space. Any YARI
//! file can be brought into this shape exactly (see [`crate::import`]).

use crate::error::{check_name, ModelError};
use crate::project::{Object, Project, Surface, Transform, V3};

impl Object {
    /// Whether it has parts (children); a group's transformations live on its parts.
    pub fn is_group(&self) -> bool {
        !self.children.is_empty()
    }

    /// This object and all objects inside it, depth first.
    pub fn walk<'a>(&'a self, f: &mut dyn FnMut(&'a Object, usize), depth: usize) {
        f(self, depth);
        for c in &self.children {
            c.walk(f, depth + 1);
        }
    }

    /// This object and all objects inside it, depth first, to change.
    pub fn walk_mut(&mut self, f: &mut dyn FnMut(&mut Object)) {
        f(self);
        for c in &mut self.children {
            c.walk_mut(f);
        }
    }

    /// Appends a world-space transformation to every part inside this object.
    pub fn apply_world(&mut self, ts: &[Transform]) {
        self.walk_mut(&mut |o| {
            if !o.is_group() {
                o.transforms.extend(ts.iter().cloned());
            }
        });
    }

    /// The number of primitives inside this object.
    pub fn primitive_count(&self) -> usize {
        let mut n = 0;
        self.walk(&mut |o, _| n += o.primitives.len(), 0);
        n
    }

    fn contains(&self, name: &str) -> bool {
        let mut found = false;
        self.walk(&mut |o, _| found |= o.name == name, 0);
        found
    }
}

/// Where an object sits: in the top-level list or in a group's children, at an index.
fn locate<'a>(list: &'a mut Vec<Object>, name: &str) -> Option<(&'a mut Vec<Object>, usize)> {
    if let Some(i) = list.iter().position(|o| o.name == name) {
        return Some((list, i));
    }
    for o in list.iter_mut() {
        if o.contains(name) {
            return locate(&mut o.children, name);
        }
    }
    None
}

impl Project {
    /// Every object name, depth first.
    pub fn object_names(&self) -> Vec<&str> {
        let mut names = Vec::new();
        for o in &self.objects {
            collect_names(o, &mut names);
        }
        names
    }

    /// The object called `name`, at any depth; the error lists the names there are.
    pub fn object(&self, name: &str) -> Result<&Object, ModelError> {
        fn find<'a>(list: &'a [Object], name: &str) -> Option<&'a Object> {
            for o in list {
                if o.name == name {
                    return Some(o);
                }
                if let Some(f) = find(&o.children, name) {
                    return Some(f);
                }
            }
            None
        }
        find(&self.objects, name).ok_or_else(|| self.object_not_found(name))
    }

    /// The object called `name`, at any depth, to change it.
    pub fn object_mut(&mut self, name: &str) -> Result<&mut Object, ModelError> {
        if self.object(name).is_err() {
            return Err(self.object_not_found(name));
        }
        match locate(&mut self.objects, name) {
            Some((list, i)) => Ok(&mut list[i]),
            None => Err(ModelError::not_found("object", name, std::iter::empty())),
        }
    }

    /// The surface an object renders with: its own, or the nearest enclosing object's
    /// (`None`: the renderer's default surface).
    pub fn effective_surface(&self, name: &str) -> Option<Surface> {
        fn search(
            list: &[Object],
            name: &str,
            inherited: Option<&Surface>,
        ) -> Option<Option<Surface>> {
            for o in list {
                let here = o.surface.as_ref().or(inherited);
                if o.name == name {
                    return Some(here.cloned());
                }
                if let Some(found) = search(&o.children, name, here) {
                    return Some(found);
                }
            }
            None
        }
        search(&self.objects, name, None).flatten()
    }

    fn object_not_found(&self, name: &str) -> ModelError {
        ModelError::not_found("object", name, self.object_names().into_iter())
    }

    /// Checks that `name` is a valid name and no object has it yet.
    pub fn check_new_object_name(&self, name: &str) -> Result<(), ModelError> {
        check_name(name)?;
        if self.object(name).is_ok() {
            return Err(ModelError::Duplicate {
                kind: "object",
                name: name.into(),
            });
        }
        Ok(())
    }

    /// `base` if no object has that name, else `base.2`, `base.3`, ...
    pub fn fresh_object_name(&self, base: &str) -> String {
        if self.object(base).is_err() {
            return base.to_string();
        }
        (2..)
            .map(|i| format!("{base}.{i}"))
            .find(|n| self.object(n).is_err())
            .unwrap_or_default()
    }

    /// Adds a new top-level object.
    pub fn add_object(&mut self, object: Object) -> Result<(), ModelError> {
        self.check_new_object_name(&object.name)?;
        self.objects.push(object);
        Ok(())
    }

    /// Removes an object (with everything inside it) and returns it.
    pub fn remove_object(&mut self, name: &str) -> Result<Object, ModelError> {
        self.object(name)?;
        match locate(&mut self.objects, name) {
            Some((list, i)) => Ok(list.remove(i)),
            None => Err(self.object_not_found(name)),
        }
    }

    /// Combines objects into a new group, which takes the place of the first of them. An
    /// object that moves and inherited its surface keeps the look it had.
    pub fn combine(&mut self, group: &str, members: &[String]) -> Result<(), ModelError> {
        self.check_new_object_name(group)?;
        if members.is_empty() {
            return Err(ModelError::bad_arg(
                "OBJECTS",
                "name at least one object to combine",
            ));
        }
        for (i, m) in members.iter().enumerate() {
            let obj = self.object(m)?;
            if members[..i].contains(m) {
                return Err(ModelError::bad_arg(m.clone(), "is named twice"));
            }
            if let Some(inner) = members
                .iter()
                .find(|other| *other != m && obj.contains(other))
            {
                return Err(ModelError::bad_arg(
                    inner.clone(),
                    format!("is inside `{m}`; combine `{m}` alone"),
                ));
            }
        }
        let (list, i) = locate(&mut self.objects, &members[0])
            .ok_or_else(|| ModelError::bad_arg(&members[0], "not found"))?;
        let first = std::mem::take(&mut list[i]);
        list[i] = Object {
            name: group.into(),
            children: vec![first],
            ..Object::default()
        };
        let inherited_here = self.effective_surface(group);
        for m in &members[1..] {
            let before = self.effective_surface(m);
            let mut obj = self.remove_object(m)?;
            if obj.surface.is_none() && before != inherited_here {
                obj.surface = Some(before.unwrap_or_default());
            }
            self.object_mut(group)?.children.push(obj);
        }
        Ok(())
    }

    /// Explodes a group into its children (in its place), or a part with several
    /// primitives into one part per primitive. Children that inherited the group's surface
    /// get a copy of it, so nothing changes colour.
    pub fn explode(&mut self, name: &str) -> Result<Vec<String>, ModelError> {
        let obj = self.object(name)?.clone();
        let parts: Vec<Object> = if obj.is_group() {
            obj.children
                .into_iter()
                .map(|mut c| {
                    if c.surface.is_none() {
                        c.surface = obj.surface.clone();
                    }
                    c
                })
                .collect()
        } else {
            if obj.primitives.len() < 2 {
                return Err(ModelError::object(
                    name,
                    "has fewer than two primitives; there is nothing to explode",
                ));
            }
            let mut parts = Vec::new();
            for (i, p) in obj.primitives.iter().enumerate() {
                let mut part_name = format!("{name}.{}", i + 1);
                while self.object(&part_name).is_ok()
                    || parts.iter().any(|o: &Object| o.name == part_name)
                {
                    part_name.push('_');
                }
                parts.push(Object {
                    name: part_name,
                    surface: obj.surface.clone(),
                    transforms: obj.transforms.clone(),
                    primitives: vec![p.clone()],
                    children: vec![],
                });
            }
            parts
        };
        let names = parts.iter().map(|p| p.name.clone()).collect();
        let (list, i) = locate(&mut self.objects, name)
            .ok_or_else(|| ModelError::not_found("object", name, std::iter::empty()))?;
        list.splice(i..=i, parts);
        Ok(names)
    }

    /// Renames an object.
    pub fn rename_object(&mut self, old: &str, new: &str) -> Result<(), ModelError> {
        self.object(old)?;
        self.check_new_object_name(new)?;
        self.object_mut(old)?.name = new.into();
        Ok(())
    }

    /// Copies an object (and everything inside it) to a new top-level object; the copies
    /// inside are renamed `NEW.<rest>` where the original was `OLD.<rest>`, else `NEW.<name>`.
    pub fn copy_object(&mut self, old: &str, new: &str) -> Result<(), ModelError> {
        self.check_new_object_name(new)?;
        let mut copy = self.object(old)?.clone();
        if copy.surface.is_none() {
            copy.surface = self.effective_surface(old);
        }
        let mut taken: Vec<String> = self.object_names().into_iter().map(String::from).collect();
        taken.push(new.into());
        copy.name = new.into();
        for c in &mut copy.children {
            rename_copies(c, old, new, &mut taken);
        }
        self.objects.push(copy);
        Ok(())
    }

    /// Translates, rotates or scales an object in world space, about `pivot`.
    pub fn transform_object(
        &mut self,
        name: &str,
        t: Transform,
        pivot: Option<V3>,
    ) -> Result<(), ModelError> {
        let mut ts = Vec::new();
        let pivot = pivot.filter(|p| *p != [0.0; 3]);
        if let Some(p) = pivot {
            ts.push(Transform::Translate([-p[0], -p[1], -p[2]]));
        }
        ts.push(t);
        if let Some(p) = pivot {
            ts.push(Transform::Translate(p));
        }
        self.object_mut(name)?.apply_world(&ts);
        Ok(())
    }
}

fn collect_names<'a>(o: &'a Object, names: &mut Vec<&'a str>) {
    names.push(&o.name);
    for c in &o.children {
        collect_names(c, names);
    }
}

fn rename_copies(o: &mut Object, old: &str, new: &str, taken: &mut Vec<String>) {
    let base = match o.name.strip_prefix(&format!("{old}.")) {
        Some(rest) => format!("{new}.{rest}"),
        None => format!("{new}.{}", o.name),
    };
    let mut name = base.clone();
    let mut i = 2;
    while taken.contains(&name) {
        name = format!("{base}.{i}");
        i += 1;
    }
    taken.push(name.clone());
    o.name = name;
    for c in &mut o.children {
        rename_copies(c, old, new, taken);
    }
}

#[cfg(test)]
mod tests;
