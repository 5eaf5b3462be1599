//! The walk's state and its view of an element: where it is (line, column, path) and how its
//! findings are reported; shared by the document walk and the layer walk.

use std::collections::HashMap;

use roxmltree::Node;

use super::diag::{LineIndex, Sink};
use super::number::{self, NumberError};
use super::Pos;
use crate::codes::manifest as codes;

/// Walk state: the text (for positions and verbatim copies) and the findings.
pub struct Ctx<'t> {
    pub text: &'t str,
    lines: LineIndex,
    pub sink: Sink,
}

/// An element with its path (`/Panorama/Layer[2]/Textures`).
#[derive(Clone)]
pub struct El<'a, 'i> {
    pub node: Node<'a, 'i>,
    pub path: String,
}

impl<'a, 'i> El<'a, 'i> {
    pub fn name(&self) -> &'i str {
        self.node.tag_name().name()
    }

    pub fn start(&self) -> usize {
        self.node.range().start
    }

    /// A plain (namespace-less) attribute's value and byte offset.
    pub fn attr(&self, name: &str) -> Option<(&'a str, usize)> {
        let a = self.node.attributes().find(|a| a.namespace().is_none() && a.name() == name)?;
        Some((a.value(), a.range().start))
    }

    /// Plain element children with their paths; the `[k]` index (1-based, among same-named
    /// siblings) is written only when a name occurs more than once.
    pub fn children(&self) -> Vec<El<'a, 'i>> {
        let kids: Vec<Node<'a, 'i>> =
            self.node.children().filter(|n| n.is_element() && n.tag_name().namespace().is_none()).collect();
        let mut totals: HashMap<&str, usize> = HashMap::new();
        for k in &kids {
            *totals.entry(k.tag_name().name()).or_default() += 1;
        }
        let mut seen: HashMap<&str, usize> = HashMap::new();
        kids.into_iter()
            .map(|node| {
                let name = node.tag_name().name();
                let k = seen.entry(name).or_default();
                *k += 1;
                let path = if totals[name] > 1 {
                    format!("{}/{}[{}]", self.path, name, k)
                } else {
                    format!("{}/{}", self.path, name)
                };
                El { node, path }
            })
            .collect()
    }
}

impl<'t> Ctx<'t> {
    pub fn new(text: &'t str, sink: Sink) -> Ctx<'t> {
        Ctx { text, lines: LineIndex::new(text), sink }
    }

    pub fn pos(&self, offset: usize) -> Pos {
        self.lines.pos(self.text, offset)
    }

    pub fn report(&mut self, code: &'static str, offset: usize, path: &str, message: String) {
        let pos = self.pos(offset);
        self.sink.push(code, pos, path, message);
    }

    /// Warn about attributes outside `known`.
    pub fn check_attributes(&mut self, el: &El, known: &[&str]) {
        for a in el.node.attributes() {
            if a.namespace().is_none() && !known.contains(&a.name()) {
                let msg = if known.is_empty() {
                    format!("<{}> takes no attributes; `{}` is ignored", el.name(), a.name())
                } else {
                    format!(
                        "<{}> has no attribute `{}` in POMC 1 (known: {}); it is ignored — check its spelling",
                        el.name(),
                        a.name(),
                        known.join(", ")
                    )
                };
                self.report(codes::UNKNOWN_ATTRIBUTE, a.range().start, &el.path, msg);
            }
        }
    }

    /// Check an element that has no children in POMC 1: its attributes, and warn about any child.
    pub fn leaf(&mut self, el: &El, known: &[&str]) {
        self.check_attributes(el, known);
        for child in el.children() {
            let msg =
                format!("<{}> has no child elements in POMC 1; <{}> is ignored", el.name(), child.name());
            self.report(codes::UNKNOWN_ELEMENT, child.start(), &child.path, msg);
        }
    }

    /// Warn about an element this version does not define in this place.
    pub fn unknown_element(&mut self, el: &El, parent: &str, known: &[&str]) {
        let msg = format!(
            "<{}> is not a POMC 1 child of <{parent}> (known: {}); it is ignored — check its spelling",
            el.name(),
            known.join(", ")
        );
        self.report(codes::UNKNOWN_ELEMENT, el.start(), &el.path, msg);
    }

    /// A required attribute, reporting `MANIFEST_MISSING_ATTRIBUTE` when absent.
    pub fn required<'a>(&mut self, el: &El<'a, '_>, name: &str, example: &str) -> Option<(&'a str, usize)> {
        let found = el.attr(name);
        if found.is_none() {
            let msg = format!("<{}> needs the attribute `{name}`, e.g. {name}=\"{example}\"", el.name());
            self.report(codes::MISSING_ATTRIBUTE, el.start(), &el.path, msg);
        }
        found
    }

    /// Report a number error on attribute `name` of `el` as `MANIFEST_NUMBER_INVALID`.
    pub fn number_error(&mut self, el: &El, name: &str, offset: usize, e: &NumberError) {
        self.report(codes::NUMBER_INVALID, offset, &el.path, format!("<{}> {}", el.name(), e.message(name)));
    }

    /// A required list of three finite numbers.
    pub fn vector3(&mut self, el: &El, name: &str, example: &str) -> Option<[f64; 3]> {
        let (value, at) = self.required(el, name, example)?;
        number::floats::<3>(value).map_err(|e| self.number_error(el, name, at, &e)).ok()
    }

    /// A duplicate of an element allowed once; the first one is used.
    pub fn duplicate(&mut self, el: &El, parent: &str) {
        let msg = format!("<{parent}> allows one <{}>; remove this one (the first is used)", el.name());
        self.report(codes::DUPLICATE_ELEMENT, el.start(), &el.path, msg);
    }
}
